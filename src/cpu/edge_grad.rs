//! `edge_grad` — CPU twin of `shaders/edge_grad.wgsl`: per candidate edge, the analytic derivative
//! of the loss with respect to its two endpoints, over the pixels it crosses, visible parts only.
//!
//! For each candidate edge the stage walks the pixels the segment crosses (a scanline DDA: the
//! rows it spans, then the columns within each row), clips the segment to each pixel with
//! Liang–Barsky, removes the parts whose outside is covered by another triangle (exact intervals
//! along the segment, from the triangles binned in the cells its box meets), and applies the closed form
//! of ARCHITECTURE.md, *The method* ([`crate::reference::closed_form`]). Each edge writes only its own slot: no atomics, and
//! the result does not depend on the thread count.

use glam::{DVec2, Vec4};
use rayon::prelude::*;

use super::bin::{self, Bins, CellGrid};
use super::edges;
use crate::engine::BackwardStats;
use crate::mirror::{EdgeGrad, RasterParams, ScreenVertex};
use crate::reference::closed_form::{clip_parameter, segment_weights};
use crate::scene::mesh::Topology;

fn position(screen: &[ScreenVertex], v: u32) -> DVec2 {
    let p = screen[v as usize].position;
    DVec2::new(p[0] as f64, p[1] as f64)
}

/// The largest f32 at most `x`.
fn at_most(x: f64) -> f32 {
    let y = x as f32;
    if y as f64 > x {
        y.next_down()
    } else {
        y
    }
}

/// The smallest f32 at least `x`.
fn at_least(x: f64) -> f32 {
    let y = x as f32;
    if (y as f64) < x {
        y.next_up()
    } else {
        y
    }
}

/// Parameter interval of `[sa, sb]` on `va + s·d` whose outside (`+ε·outward`) is inside triangle
/// `q`, or that `q` takes over as a coincident edge (`yields`, see below). Exact for shared vertices
/// and coincident edges (the products vanish exactly), so a face adjacent to the edge never
/// occludes it.
///
/// An edge of `q` on the segment's line with `q` on the segment's *inside* covers none of its
/// outside; but when it is another mesh edge lying over the same stretch of boundary (a duplicate
/// surface, the front and back outlines of a box seen face-on), the area there moves once, not
/// once per edge. `yields` says that `q` ranks before the segment's edge ([`coincident_rank`]):
/// then the stretch of `q`'s edge counts as removed from this segment. Ranks are a strict order,
/// so of the coincident edges over a stretch, the one that ranks first keeps it and every other
/// one leaves it out.
fn occluded_interval(
    q: [DVec2; 3],
    va: DVec2,
    vb: DVec2,
    outward: DVec2,
    (sa, sb): (f64, f64),
    yields: bool,
) -> Option<(f64, f64)> {
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
            if alpha < 0.0 || (alpha == 0.0 && !covers_line(inward.dot(outward), yields)) {
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

/// Whether an occluder edge lying on the segment's line, whose inward normal has dot product `dot`
/// with the segment's outward normal, removes the stretch it spans: when its triangle lies on the
/// segment's outside (it covers it), or on the same side when the triangle ranks first among
/// coincident edges (`yields`, see [`occluded_interval`]).
#[inline]
fn covers_line(dot: f64, yields: bool) -> bool {
    dot > 0.0 || (dot < 0.0 && yields)
}

/// The rank of candidate edge `e` among coincident edges: the lowest index of its faces with a
/// non-zero orientation (the faces that cover its inside; the topology lists an edge's faces in
/// increasing order, and a candidate has at least one). A stretch of `e` that lies on an edge of a
/// triangle `t < rank` on the same side is left to that triangle's edge; `e`'s own faces never
/// rank before it. Of two coincident edges `e1`, `e2` exactly one ranks first, and its lowest
/// covering face takes the stretch from the other.
fn coincident_rank(screen: &[ScreenVertex], topology: &Topology, e: u32) -> u32 {
    let triangles = topology.triangles();
    let faces = topology.edge_faces(e as usize);
    faces.iter().copied().find(|&f| edges::face_orientation(screen, triangles[f as usize]) != 0).unwrap_or(u32::MAX)
}

/// One piece of a candidate edge: its part in one pixel with a non-zero incoming gradient.
#[derive(Clone, Copy, Debug)]
struct Segment {
    /// The cells of the occluder grid ([`CellGrid`]) whose lists hold the segment's occluders
    /// ([`segment_cells`]): `[cx0, cy0, cx1, cy1]`, inclusive.
    cells: [u32; 4],
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
fn edge_segments(
    params: &RasterParams,
    grid: &CellGrid,
    d_image: &[f32],
    va: DVec2,
    vb: DVec2,
    out: &mut Vec<Segment>,
) {
    let d = vb - va;
    let (w, h) = (params.width as f64, params.height as f64);
    let mut s = (0.0, 1.0);
    if !(clip_parameter(va.x, d.x, 0.0, w, &mut s) && clip_parameter(va.y, d.y, 0.0, h, &mut s)) {
        return;
    }
    let scale = (params.inside - params.outside) as f64;
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
            out.push(Segment { cells: segment_cells(params, grid, va, d, c), s: c, g });
        }
    }
}

/// The cells `[cx0, cy0, cx1, cy1]` of `grid` that hold every triangle whose float box meets
/// the box of the part `c` of `va + s·d`: those that the box, shrunk by a quarter unit on each
/// side (or reduced to its centre when narrower than half a unit), meets, within the grid.
///
/// Why they are enough: a triangle whose float box holds a point `p` of the segment's box is
/// listed in every cell that its snapped box, grown by one unit, meets; snapping moves a vertex
/// by at most half a unit, so that grown box holds every point within half a unit of `p`, and
/// the shrunk box has such a point (a quarter unit from `p` at most; the quarter unit left over
/// absorbs any rounding in the scaling to units). A segment inside one pixel thus meets one tile
/// even where it ends on the pixel's border, as the pixel's own tile did.
fn segment_cells(params: &RasterParams, grid: &CellGrid, va: DVec2, d: DVec2, c: (f64, f64)) -> [u32; 4] {
    let (p, q) = (va + c.0 * d, va + c.1 * d);
    let (lo, hi) = (p.min(q) * params.units as f64, p.max(q) * params.units as f64);
    let cell = grid.cell_units as f64;
    let range = |lo: f64, hi: f64, last: u32| {
        let (a, b) = if hi - lo >= 0.5 { (lo + 0.25, hi - 0.25) } else { ((lo + hi) / 2.0, (lo + hi) / 2.0) };
        let index = |x: f64| ((x / cell).floor().max(0.0) as u32).min(last);
        (index(a), index(b))
    };
    let (x0, x1) = range(lo.x, hi.x, grid.cells_x - 1);
    let (y0, y1) = range(lo.y, hi.y, grid.cells_y - 1);
    [x0, y0, x1, y1]
}

/// Whether sorted `intervals` leave no gap in `c`: then the sweep of [`visible_weights`] adds no
/// visible piece, and any further interval would not add one either.
fn covers(intervals: &[(f64, f64)], c: (f64, f64)) -> bool {
    let mut cursor = c.0;
    for &(lo, hi) in intervals {
        if lo > cursor {
            return false;
        }
        cursor = cursor.max(hi);
    }
    cursor >= c.1
}

/// Buffers reused from segment to segment.
#[derive(Clone, Debug, Default)]
struct Scratch {
    /// Occluded parameter intervals.
    intervals: Vec<(f64, f64)>,
}

/// Endpoint weights `[∫(1 − s), ∫s]` over the visible part of `segment`: the parts of its
/// parameter interval whose outside is covered by no triangle of the lists of its cells (a
/// triangle listed in several is tested again, which adds the same interval again and changes
/// nothing), and that no coincident edge ranking before the edge (`rank`, [`coincident_rank`])
/// carries. `lists` maps a cell of the grid (`cells_x` per row) to its list in `bins`.
#[allow(clippy::too_many_arguments)]
fn visible_weights(
    (bins, lists, cells_x): (&Bins, &[u32], usize),
    (va, vb, outward): (DVec2, DVec2, DVec2),
    rank: u32,
    segment: &Segment,
    scratch: &mut Scratch,
) -> (f64, f64) {
    let c = segment.s;
    let d = vb - va;
    let (bb_lo, bb_hi) = (va + c.0 * d, va + c.1 * d);
    let (bb_lo, bb_hi) = (bb_lo.min(bb_hi), bb_lo.max(bb_hi));
    // A triangle whose box misses the segment's box covers none of it. For an f32 `x`,
    // `x > bb_hi` is `x > (largest f32 ≤ bb_hi)` and `x < bb_lo` is `x < (smallest f32 ≥ bb_lo)`,
    // so the test runs exactly in f32, on the boxes stored as [xmin, ymin, −xmax, −ymax].
    let miss = Vec4::new(at_most(bb_hi.x), at_most(bb_hi.y), -at_least(bb_lo.x), -at_least(bb_lo.y));
    // Occluded intervals, kept sorted by (lo, hi). Once they cover the whole segment nothing
    // further can uncover any of it: the segment is hidden and the scan stops.
    let Scratch { intervals } = scratch;
    intervals.clear();
    let [cx0, cy0, cx1, cy1] = segment.cells.map(|c| c as usize);
    for cell in (cy0..=cy1).flat_map(|cy| cy * cells_x + cx0..=cy * cells_x + cx1) {
        let n = lists[cell] as usize;
        let list = bins.offsets[n] as usize..bins.offsets[n + 1] as usize;
        let list_start = list.start;
        let (boxes, vertices) = (&bins.boxes[list.clone()], &bins.vertices[list]);
        // The entries whose box meets the segment's, gathered block by block without a branch
        // per entry (about one in five passes, unpredictably) and without a bounds check (an
        // index below the block length, masked).
        for (block, chunk) in boxes.chunks(SCAN_BLOCK).enumerate() {
            let mut met = [0u8; SCAN_BLOCK];
            let mut count = 0;
            for (k, b) in chunk.iter().enumerate() {
                met[count & (SCAN_BLOCK - 1)] = k as u8;
                count += !Vec4::from_array(*b).cmpgt(miss).any() as usize;
            }
            for k in met[..count].iter().map(|&k| block * SCAN_BLOCK + k as usize) {
                let q = vertices[k].map(|p| DVec2::new(p[0] as f64, p[1] as f64));
                // A triangle on the inside of the edge's line (closed half-plane) covers no point just
                // outside it: the usual case (the edge's own faces and their neighbours). The signs
                // are exact (f32 differences, their products and one sum of two in f64).
                // Unless two of its vertices lie on the line (a coincident edge) and it ranks first.
                let side = q.map(|p| (p - va).dot(outward));
                let yields = bins.triangles[list_start + k] < rank;
                if side.iter().all(|&h| h <= 0.0) && !(yields && side.iter().filter(|&&h| h == 0.0).count() >= 2) {
                    continue;
                }
                if let Some(iv) = occluded_interval(q, va, vb, outward, c, yields) {
                    let at = intervals.partition_point(|x| x.0.total_cmp(&iv.0).then(x.1.total_cmp(&iv.1)).is_le());
                    intervals.insert(at, iv);
                    if covers(intervals, c) {
                        return (0.0, 0.0);
                    }
                }
            }
        }
    }
    let (mut visible_a, mut visible_b, mut cursor) = (0.0, 0.0, c.0);
    for &(lo, hi) in intervals.iter().chain(std::iter::once(&(c.1, c.1))) {
        if lo > cursor {
            let [ka, kb] = segment_weights(cursor, lo);
            visible_a += ka;
            visible_b += kb;
        }
        cursor = cursor.max(hi);
    }
    (visible_a, visible_b)
}

/// Sums the visible weights of an edge's segments (in walk order) into its slot.
fn accumulate(
    lists: (&Bins, &[u32], usize),
    geometry: (DVec2, DVec2, DVec2),
    rank: u32,
    segments: &[Segment],
    scratch: &mut Scratch,
) -> (EdgeGrad, BackwardStats) {
    let mut stats = BackwardStats::default();
    let (mut wa, mut wb) = (0.0f64, 0.0f64);
    for segment in segments {
        stats.segments += 1;
        let (visible_a, visible_b) = visible_weights(lists, geometry, rank, segment, scratch);
        if visible_a != 0.0 || visible_b != 0.0 {
            stats.visible_segments += 1;
        }
        wa += segment.g * visible_a;
        wb += segment.g * visible_b;
    }
    let outward = geometry.2;
    let (ga, gb) = (outward * wa, outward * wb);
    (EdgeGrad { a: [ga.x as f32, ga.y as f32], b: [gb.x as f32, gb.y as f32] }, stats)
}

/// Entries of an occluder list box-tested per block of [`visible_weights`] (at most 256, a power of
/// two).
const SCAN_BLOCK: usize = 64;

/// Candidate edges per parallel task.
const EDGES_PER_TASK: usize = 64;

/// The buffers of [`edge_grad`], kept from call to call (one per view in flight).
#[derive(Clone, Debug, Default)]
pub struct EdgeGradScratch {
    /// Each task's segments (in walk order) and the end of each candidate's among them.
    walks: Vec<(Vec<Segment>, Vec<u32>)>,
    /// The list number of each cell of the grid, `u32::MAX` for a cell no segment meets.
    cell_lists: Vec<u32>,
    /// The occluder lists of the cells that segments meet.
    lists: bin::CellBins,
    /// Each candidate's slot and statistics.
    results: Vec<(EdgeGrad, BackwardStats)>,
    /// Each task's scan buffers.
    scans: Vec<Scratch>,
}

/// The gradient slot of every candidate edge: walks the pixels it crosses, keeps the visible
/// parts of its segments and applies the closed form. Occluder lists are built only for the tiles
/// the edges cross with a non-zero `∂L/∂I` (the CPU's lazy form of the `bin` stage: most tiles
/// hold no silhouette, and where `∂L/∂I` is zero nothing is looked up), and over the cells of
/// `grid` rather than the tiles ([`CellGrid::for_extent`]: cells smaller than a pixel when the
/// triangles are).
///
/// Reads screen vertices, the triangles and their snapped boxes (as the `coverage` pass writes
/// them, [`bin::snapped_boxes`]), the candidates `(edge, side)` of the `edges`
/// stage and `∂L/∂I`; writes one [`EdgeGrad`] per candidate into `slots` (same order).
/// The result is the same as with the full bins of [`bin::bin`] (tested): an occluder of a
/// segment is in the list of one of the segment's cells, and a triangle found twice or one that
/// is no occluder adds nothing. `scratch` holds the buffers of the walk, the lists and the scans
/// from call to call: a loop of backward passes allocates only where a buffer must grow.
#[allow(clippy::too_many_arguments)]
pub fn edge_grad(
    params: &RasterParams,
    grid: CellGrid,
    screen: &[ScreenVertex],
    boxes: &[[i32; 4]],
    topology: &Topology,
    candidates: &[(u32, i32)],
    d_image: &[f32],
    slots: &mut Vec<EdgeGrad>,
    scratch: &mut EdgeGradScratch,
) -> BackwardStats {
    let EdgeGradScratch { walks, cell_lists, lists: cell_bins, results, scans } = scratch;
    let edges = topology.edges();
    let geometry = |&(e, side): &(u32, i32)| edge_geometry(screen, edges[e as usize], side);
    // Walk every candidate edge once: its segments, grouped per task in candidate order.
    // Buffers only grow: the candidate count changes from step to step, and a task's buffers
    // dropped now would be allocated again the next time.
    let tasks = candidates.len().div_ceil(EDGES_PER_TASK);
    if walks.len() < tasks {
        walks.resize_with(tasks, Default::default);
        scans.resize_with(tasks, Scratch::default);
    }
    walks[..tasks].par_iter_mut().zip(candidates.par_chunks(EDGES_PER_TASK)).for_each(|((segments, ends), chunk)| {
        segments.clear();
        ends.clear();
        for candidate in chunk {
            if let Some((va, vb, _)) = geometry(candidate) {
                edge_segments(params, &grid, d_image, va, vb, segments);
            }
            ends.push(segments.len() as u32);
        }
    });
    let walks = &walks[..tasks];
    // Number the cells that a segment meets, and list the triangles of those cells only.
    cell_lists.clear();
    cell_lists.resize(grid.count(), u32::MAX);
    let mut lists = 0u32;
    let cells_x = grid.cells_x as usize;
    for (segments, _) in walks {
        for segment in segments {
            let [cx0, cy0, cx1, cy1] = segment.cells.map(|c| c as usize);
            for cy in cy0..=cy1 {
                for list in &mut cell_lists[cy * cells_x + cx0..=cy * cells_x + cx1] {
                    if *list == u32::MAX {
                        *list = lists;
                        lists += 1;
                    }
                }
            }
        }
    }
    bin::bin_tiles(params, grid, screen, topology.triangles(), boxes, cell_lists, lists as usize, cell_bins);
    let bins = &cell_bins.bins;
    results.clear();
    results.resize(candidates.len(), (EdgeGrad::default(), BackwardStats::default()));
    results
        .par_chunks_mut(EDGES_PER_TASK)
        .zip(candidates.par_chunks(EDGES_PER_TASK))
        .zip(walks)
        .zip(&mut scans[..tasks])
        .for_each(|(((out, chunk), (segments, ends)), scratch)| {
            let mut start = 0;
            for ((result, candidate), &end) in out.iter_mut().zip(chunk).zip(ends) {
                let pieces = &segments[start..end as usize];
                start = end as usize;
                if let Some(g) = geometry(candidate) {
                    // The rank matters only to a segment's occluders: an edge with none skips it.
                    let rank =
                        if pieces.is_empty() { u32::MAX } else { coincident_rank(screen, topology, candidate.0) };
                    *result = accumulate((bins, cell_lists, cells_x), g, rank, pieces, scratch);
                }
            }
        });
    slots.clear();
    slots.extend(results.iter().map(|r| r.0));
    results.iter().fold(BackwardStats::default(), |a, r| a + r.1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::bin;

    /// The stage as first written: full bins, every listed triangle tested in f64, no early exit.
    #[allow(clippy::too_many_arguments)]
    fn reference_gradient(
        params: &RasterParams,
        screen: &[ScreenVertex],
        triangles: &[[u32; 3]],
        bins: &Bins,
        d_image: &[f32],
        edge: [u32; 2],
        inside: i32,
        rank: u32,
    ) -> (EdgeGrad, BackwardStats) {
        let mut stats = BackwardStats::default();
        let Some((va, vb, outward)) = edge_geometry(screen, edge, inside) else {
            return (EdgeGrad::default(), stats);
        };
        let d = vb - va;
        let (mut wa, mut wb) = (0.0f64, 0.0f64);
        let mut segments = Vec::new();
        let mut s = (0.0, 1.0);
        if !(clip_parameter(va.x, d.x, 0.0, params.width as f64, &mut s)
            && clip_parameter(va.y, d.y, 0.0, params.height as f64, &mut s))
        {
            return (EdgeGrad::default(), stats);
        }
        let (y0, y1) = (va.y + s.0 * d.y, va.y + s.1 * d.y);
        for i in (y0.min(y1).ceil() as i64 - 1).max(0)..=(y0.max(y1).floor() as i64).min(params.height as i64 - 1) {
            let mut r = s;
            if !clip_parameter(va.y, d.y, i as f64, i as f64 + 1.0, &mut r) {
                continue;
            }
            let (x0, x1) = (va.x + r.0 * d.x, va.x + r.1 * d.x);
            for j in (x0.min(x1).ceil() as i64 - 1).max(0)..=(x0.max(x1).floor() as i64).min(params.width as i64 - 1) {
                let mut c = r;
                if clip_parameter(va.x, d.x, j as f64, j as f64 + 1.0, &mut c) && c.1 > c.0 {
                    let on_border = (d.y == 0.0 && (va.y == i as f64 || va.y == i as f64 + 1.0))
                        || (d.x == 0.0 && (va.x == j as f64 || va.x == j as f64 + 1.0));
                    segments.push((i, j, c, on_border));
                }
            }
        }
        let scale = (params.inside - params.outside) as f64;
        for (i, j, c, on_border) in segments {
            let g = d_image[i as usize * params.width as usize + j as usize] as f64
                * scale
                * if on_border { 0.5 } else { 1.0 };
            if g == 0.0 {
                continue;
            }
            stats.segments += 1;
            let (lo, hi) = (va + c.0 * d, va + c.1 * d);
            let (lo, hi) = (lo.min(hi), lo.max(hi));
            let mut found = Vec::new();
            let tile = (i as u32 / params.tile_size) * params.tiles_x + j as u32 / params.tile_size;
            for (t, b, _) in bins.tile(tile as usize) {
                let b = [b[0], b[1], -b[2], -b[3]].map(|x| x as f64);
                if b[0] > hi.x || b[1] > hi.y || b[2] < lo.x || b[3] < lo.y {
                    continue;
                }
                let q = triangles[t as usize].map(|v| position(screen, v));
                found.extend(occluded_interval(q, va, vb, outward, c, t < rank));
            }
            found.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
            let (mut visible_a, mut visible_b, mut cursor) = (0.0, 0.0, c.0);
            for &(lo, hi) in found.iter().chain(std::iter::once(&(c.1, c.1))) {
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
        let (ga, gb) = (outward * wa, outward * wb);
        (EdgeGrad { a: [ga.x as f32, ga.y as f32], b: [gb.x as f32, gb.y as f32] }, stats)
    }

    /// Runs the stage on a scene and asserts that every slot and the statistics are the
    /// reference's; returns the statistics.
    fn compare_with_reference(
        params: &RasterParams,
        grid: CellGrid,
        screen: &[ScreenVertex],
        topology: &Topology,
        d_image: &[f32],
        what: &str,
    ) -> BackwardStats {
        let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
        let mut orientation = vec![0i8; topology.triangles().len()];
        edges::face_orientations(screen, topology.triangles(), &mut orientation);
        let mut candidates = Vec::new();
        edges::edges(&orientation, topology, &mut candidates);
        let mut slots = Vec::new();
        let boxes = bin::snapped_boxes(&snapped, topology.triangles());
        let mut scratch = EdgeGradScratch::default();
        let stats = edge_grad(params, grid, screen, &boxes, topology, &candidates, d_image, &mut slots, &mut scratch);
        let mut full = Bins::default();
        bin::bin(params, screen, &snapped, topology.triangles(), &mut full);
        let mut expected = BackwardStats::default();
        for (&(e, side), slot) in candidates.iter().zip(&slots) {
            let edge = topology.edges()[e as usize];
            let rank = coincident_rank(screen, topology, e);
            let (grad, s) = reference_gradient(params, screen, topology.triangles(), &full, d_image, edge, side, rank);
            assert_eq!(grad, *slot, "{what} edge {e}");
            expected = expected + s;
        }
        assert_eq!(stats, expected, "{what}");
        stats
    }

    /// Lists longer than a scan block ([`SCAN_BLOCK`]): two dense overlapping spheres in a small
    /// image, listed per tile, so that a segment's occluders sit in every block of its list and at
    /// the block ends, and each sphere hides part of the other's outline; the stage must give the
    /// reference's bits.
    #[test]
    fn long_lists_same_bits_as_the_reference() {
        let sphere = crate::scene::shapes::icosphere(4);
        let n = sphere.positions().len() as u32;
        let pair = crate::scene::mesh::Mesh::new(
            sphere
                .positions()
                .iter()
                .copied()
                .chain(sphere.positions().iter().map(|p| *p * 0.8 + glam::Vec3::new(0.7, 0.4, 0.5)))
                .collect(),
            sphere.triangles().iter().copied().chain(sphere.triangles().iter().map(|t| t.map(|v| v + n))).collect(),
        )
        .unwrap();
        let (w, h) = (12, 10);
        let mut params = RasterParams::new(w, h, 4, 1.0, 0.0).unwrap();
        params.set_tile_size(4);
        let screen: Vec<ScreenVertex> = pair
            .positions()
            .iter()
            .map(|p| {
                let (x, y) = (p.x as f64 + 0.2 * p.z as f64, p.y as f64 - 0.3 * p.z as f64);
                let q = [w as f64 * (0.35 + 0.3 * x), h as f64 * (0.4 + 0.3 * y)];
                ScreenVertex { position: q.map(|c| c as f32), valid: 1, pad: 0 }
            })
            .collect();
        let d_image: Vec<f32> = (0..params.pixel_count()).map(|k| 0.25 + (k % 7) as f32 * 0.1).collect();
        let grid = CellGrid::tiles(&params);
        let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
        let mut full = Bins::default();
        bin::bin(&params, &screen, &snapped, pair.triangles(), &mut full);
        let longest = (0..params.tiles_x * params.tiles_y).map(|t| full.tile(t as usize).count()).max().unwrap();
        assert!(longest > 4 * SCAN_BLOCK, "lists of at most {longest} entries do not span several blocks");
        let stats = compare_with_reference(&params, grid, &screen, pair.topology(), &d_image, "two dense spheres");
        assert!(stats.segments > stats.visible_segments, "no hidden segment: {stats:?}");
        assert!(stats.visible_segments > 0, "no visible segment: {stats:?}");
    }

    /// The stage (lazy lists, f32 box test, gathered hits, early exit on hidden segments) gives the
    /// reference's bits, on random folded meshes with overlaps, ties on pixel borders, coincident
    /// edges (a mesh with a copy of itself) and a sparse `∂L/∂I`.
    #[test]
    fn same_bits_as_the_reference() {
        let mut seed = 0x6a09_e667_f3bc_c908u64;
        let mut rand = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let single = crate::scene::shapes::icosphere(2);
        // The sphere and an exact copy of it: every silhouette edge coincides with its copy's.
        let n = single.positions().len() as u32;
        let doubled = crate::scene::mesh::Mesh::new(
            single.positions().iter().chain(single.positions()).copied().collect(),
            single.triangles().iter().copied().chain(single.triangles().iter().map(|t| t.map(|v| v + n))).collect(),
        )
        .unwrap();
        let mut hidden = 0;
        for case in 0..40 {
            let (w, h) = (20 + case % 7, 16 + case % 5);
            let mut params = RasterParams::new(w, h, 4, 1.0, 0.0).unwrap();
            params.set_tile_size([1, 2, 4][case as usize % 3]);
            let m = [rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0];
            let topology = if case % 3 == 1 { doubled.topology() } else { single.topology() };
            let mut screen: Vec<ScreenVertex> = single
                .positions()
                .iter()
                .map(|p| {
                    let (x, y) = (p.x as f64, p.y as f64 + 0.3 * p.z as f64);
                    let mut q = [
                        w as f64 * (0.5 + 0.45 * (m[0] * x + m[1] * y)) + 0.3 * (rand() - 0.5),
                        h as f64 * (0.5 + 0.45 * (m[2] * x + m[3] * y)) + 0.3 * (rand() - 0.5),
                    ];
                    if case % 4 == 0 {
                        q = q.map(|c| (c * 2.0).round() / 2.0); // on pixel borders and centres
                    }
                    ScreenVertex { position: q.map(|c| c as f32), valid: 1, pad: 0 }
                })
                .collect();
            if case % 3 == 1 {
                screen.extend_from_within(..);
            }
            let d_image: Vec<f32> = (0..params.pixel_count())
                .map(|_| if rand() < 0.3 { 0.0 } else { (rand() * 2.0 - 1.0) as f32 })
                .collect();
            // Occluders listed per tile, and per cell of finer grids (one not a power of two).
            let grid = match case % 4 {
                0 => CellGrid::tiles(&params),
                1 => CellGrid::new(&params, params.units / 4),
                2 => CellGrid::new(&params, params.units / 16),
                _ => CellGrid::new(&params, 3 * params.units / 5),
            };
            let stats = compare_with_reference(&params, grid, &screen, topology, &d_image, &format!("case {case}"));
            hidden += stats.segments - stats.visible_segments;
        }
        assert!(hidden > 100, "too few hidden segments ({hidden}) to test the early exit");
    }
}

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
use super::coverage::BackFaceSkip;
use crate::engine::BackwardStats;
use crate::mirror::{EdgeGrad, RasterParams, ScreenVertex};
use crate::reference::closed_form::{clip_parameter, segment_weights};
use crate::scene::mesh::Topology;

fn position(screen: &[ScreenVertex], v: u32) -> DVec2 {
    let p = screen[v as usize].position;
    DVec2::new(p[0] as f64, p[1] as f64)
}

/// `x.floor()`, inline: on x86-64's baseline (no SSE4.1) `f64::floor` and `f64::ceil` are calls
/// into libm, about 1% of a pose fit's time from the walk and the cell ranges of this stage.
/// Exact (equal to `f64::floor`, up to the sign of a zero) for every `x`: below 2⁵² in magnitude through the
/// integer conversion, otherwise (already an integer, or not finite) through `f64::floor`.
#[inline]
fn floor(x: f64) -> f64 {
    if x.abs() < 4_503_599_627_370_496.0 {
        let t = x as i64 as f64;
        if t > x {
            t - 1.0
        } else {
            t
        }
    } else {
        x.floor()
    }
}

/// `x.ceil()`, inline and exact, as [`floor`].
#[inline]
fn ceil(x: f64) -> f64 {
    -floor(-x)
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
fn coincident_rank(orientation: &[i8], topology: &Topology, e: u32) -> u32 {
    let faces = topology.edge_faces(e as usize);
    faces.iter().copied().find(|&f| orientation[f as usize] != 0).unwrap_or(u32::MAX)
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
        let index = |x: f64| (floor(x / cell).max(0.0) as u32).min(last);
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
    /// One bit per triangle: the negative rank faces of candidate edges ([`bin::BackFaces::kept`]).
    kept: Vec<u64>,
}

/// The gradient slot of every candidate edge: walks the pixels it crosses, keeps the visible
/// parts of its segments and applies the closed form. Occluder lists are built only for the tiles
/// the edges cross with a non-zero `∂L/∂I` (the CPU's lazy form of the `bin` stage: most tiles
/// hold no silhouette, and where `∂L/∂I` is zero nothing is looked up), and over the cells of
/// `grid` rather than the tiles ([`CellGrid::for_extent`]: cells smaller than a pixel when the
/// triangles are).
///
/// Reads screen vertices, the triangles, their snapped boxes (as the `coverage` pass writes
/// them, [`bin::snapped_boxes`]) and orientations (one per triangle, as
/// [`face_orientations`](super::edges::face_orientations) writes them), the candidates
/// `(edge, side)` of the `edges` stage and `∂L/∂I`; writes one [`EdgeGrad`] per candidate into
/// `slots` (same order).
/// The result is the same as with the full bins of [`bin::bin`] (tested): an occluder of a
/// segment is in the list of one of the segment's cells, and a triangle found twice or one that
/// is no occluder adds nothing. With `back_faces` (the boxes of the mesh's oriented boundary in
/// this view, as [`bin::back_face_boundary`] gives them: only when no triangle is culled), the lists leave out the negative triangles that
/// cover nothing the others do not ([`bin::BackFaces`]): the same covered points, so the same
/// visible intervals (their end points can come from another triangle through the same edge,
/// which can move them by a rounding of the last bit, far below the `f32` slots' precision).
/// `scratch` holds the buffers of the walk, the lists and the scans
/// from call to call: a loop of backward passes allocates only where a buffer must grow.
#[allow(clippy::too_many_arguments)]
pub fn edge_grad(
    params: &RasterParams,
    grid: CellGrid,
    screen: &[ScreenVertex],
    boxes: &[[i32; 4]],
    orientation: &[i8],
    back_faces: Option<&BackFaceSkip>,
    topology: &Topology,
    candidates: &[(u32, i32)],
    d_image: &[f32],
    slots: &mut Vec<EdgeGrad>,
    scratch: &mut EdgeGradScratch,
) -> BackwardStats {
    let EdgeGradScratch { walks, cell_lists, lists: cell_bins, results, scans, kept } = scratch;
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
    // A candidate's rank face (its lowest face of non-zero orientation, [`coincident_rank`])
    // stays in the lists when it is a negative one: the coincident-edge rule compares it.
    let back_faces = back_faces.map(|boundary| {
        kept.clear();
        kept.resize(orientation.len().div_ceil(64), 0);
        for &(e, _) in candidates {
            let f = coincident_rank(orientation, topology, e);
            if f != u32::MAX && orientation[f as usize] < 0 {
                kept[f as usize / 64] |= 1 << (f % 64);
            }
        }
        bin::BackFaces { boundary, kept }
    });
    bin::bin_tiles(
        params,
        grid,
        screen,
        topology,
        (boxes, orientation),
        back_faces,
        cell_lists,
        lists as usize,
        cell_bins,
    );
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
                        if pieces.is_empty() { u32::MAX } else { coincident_rank(orientation, topology, candidate.0) };
                    *result = accumulate((bins, cell_lists, cells_x), g, rank, pieces, scratch);
                }
            }
        });
    slots.clear();
    slots.extend(results.iter().map(|r| r.0));
    results.iter().fold(BackwardStats::default(), |a, r| a + r.1)
}

#[cfg(test)]
mod tests;

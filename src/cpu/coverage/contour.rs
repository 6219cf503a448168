//! Coverage from the contour: the sample masks of every triangle's union, computed from the mesh
//! edges that do not cancel in this view rather than by drawing the triangles.
//!
//! Why this is exact. For a triangle of snapped area `A ≠ 0` the top-left rule's indicator at a
//! sample `p` equals `sign(A)` times the sum, over its directed edges `a → b` in the mesh's vertex
//! order, of the half-open crossing count `χ(a → b, p)` (`+1` when `a.y ≤ p.y < b.y` and `p` lies
//! strictly left of the edge, `−1` when `b.y ≤ p.y < a.y` and likewise, else 0; see
//! [`BackFaceSkip`](super::BackFaceSkip), whose tests check the identity exhaustively on a small
//! grid). Summed over the triangles of positive area, and over all triangles of non-zero area:
//!
//! - `N₊(p) = Σ_e w₊(e) · χ(e, p)`, the number of positive triangles covering `p`;
//! - `D(p) = N₊(p) − N₋(p) = Σ_e w(e) · χ(e, p)`,
//!
//! where, for an undirected edge `[a, b]`, `w₊` is the number of positive faces that run it
//! `a → b` minus those that run it `b → a`, and `w` the same over the faces of either sign. An edge
//! inside the silhouette, between two faces of the same orientation, has `w₊ = w = 0` and drops
//! out: what is left is the view's contour (and the mesh's open boundary). A sample is covered
//! when `N₊ > 0` or `N₋ = N₊ − D > 0`, that is when `N₊ > min(0, D)`. Faces with a clipped vertex
//! or zero snapped area are in neither sum, as they are in no triangle's coverage.
//!
//! On one sample row, `χ(e, ·)` is a step: `1` left of the edge's crossing, `0` right of it. So
//! each remaining edge leaves one *crossing* per sample row it spans (the last sample column
//! strictly left of it, found with one exact division and then stepped row by row), and a row's
//! covered samples are the spans between its crossings where the running sums, swept from the
//! right, satisfy the rule. The work is proportional to the contour's crossings and the covered
//! spans, not to the number of triangles.
//!
//! What remains proportional to the mesh is one pass over the faces (their snapped signs) and one
//! over the edges (their weights). The forward runs the `edges` stage in the same two passes
//! ([`coverage_and_edges`]): the float orientation of each face beside its snapped sign, and
//! whether each edge is a candidate beside its crossings, so each face's vertices and each
//! edge's faces are read once for both stages. Where a block of faces' snapped areas are far
//! enough from zero that the float orientations must have their signs (`OrientationBound`),
//! the faces' float vertices are not read at all (most blocks: 70% of the bunny's at 16², 90% at
//! 64²); in the other blocks only the faces within the bound read theirs.

use super::bands::Band;
use super::setup::TriangleSummary;
use super::triangle::floor_div;
use crate::cpu::edges::edge_side;
use crate::mirror::{RasterParams, ScreenVertex};
use crate::scene::mesh::Topology;
use faces::{code_sign, FacePass};

/// Edges from which the pass over the edges runs in two halves side by side.
const PARALLEL_EDGES: usize = 32768;

/// Crossings from which the sweep splits its rows into halves swept in parallel.
const PARALLEL_CROSSINGS: usize = 16384;

/// The buffers of [`coverage`], kept from forward to forward.
#[derive(Clone, Debug, Default)]
pub struct ContourScratch {
    /// The sign of every face's snapped area (0: a clipped vertex or zero area), with its float
    /// orientation in [`coverage_and_edges`] (`faces::face_code`).
    signs: Vec<i8>,
    /// Crossings in the order the edges produce them (of the first half of the edges when the
    /// edge pass is split in two).
    crossings: Vec<Crossing>,
    /// The crossings and candidates of the second half of the edges, when the pass is split.
    second_half: (Vec<Crossing>, Vec<(u32, i32)>),
    /// The same, grouped by sample row.
    by_row: Vec<Crossing>,
    /// `row_offsets[r]..row_offsets[r + 1]` indexes `by_row` for sample row `r`.
    row_offsets: Vec<u32>,
}

/// Where one contour edge crosses one sample row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Crossing {
    /// Sample row.
    row: u32,
    /// The last sample column strictly left of the edge (at most the image's last column; a
    /// crossing with no column left of it is not recorded).
    last: i32,
    /// Its weight in `N₊`.
    positive: i32,
    /// Its weight in `D = N₊ − N₋`.
    net: i32,
}

/// `coverage`: writes every pixel's sample mask from the view's contour (see the module's notes
/// for why the masks are exact), the same bits as drawing every triangle
/// ([`draw_triangles`](super::draw_triangles)). Reads the snapped vertices and the topology;
/// writes `masks` (`pixel_count · words_per_pixel` words) and returns the summary the `bin`
/// stage's tile size is chosen from. `scratch` keeps the pass's buffers from call to call.
pub fn coverage(
    params: &RasterParams,
    snapped: &[[i32; 2]],
    topology: &Topology,
    masks: &mut [u32],
    scratch: &mut ContourScratch,
) -> TriangleSummary {
    let no_edges = EdgesStage { screen: &[], orientation: &mut [], candidates: &mut Vec::new() };
    passes::<false>(params, snapped, topology, masks, scratch, no_edges)
}

/// The outputs of the `edges` stage ([`face_orientations`](crate::cpu::edges::face_orientations)
/// and [`edges`](crate::cpu::edges::edges)) and the screen vertices they are computed from.
pub struct EdgesStage<'a> {
    /// The view's screen vertices.
    pub screen: &'a [ScreenVertex],
    /// One orientation per face (written).
    pub orientation: &'a mut [i8],
    /// The candidate edges `(edge, side)` in edge order (cleared, then written).
    pub candidates: &'a mut Vec<(u32, i32)>,
}

/// [`coverage`] and the `edges` stage in the same two passes over the mesh, the forward's way:
/// the pass over the faces computes each face's snapped sign and its float orientation
/// ([`face_orientation`](crate::cpu::edges::face_orientation)) from one read of its vertex
/// indices, and the pass over the edges finds each edge's crossings and whether it is a
/// candidate from one read of its faces. `snapped` must be the snap of `edges.screen`
/// ([`RasterParams::snap_vertex`]: a clipped vertex is the invalid snapped one, which is how the
/// orientations tell clipped faces). The masks, the summary, the orientations and the candidates
/// are the same as [`coverage`]'s and the `edges` stage's functions give (tested).
///
/// Panics when `edges.orientation` does not hold one entry per face.
pub fn coverage_and_edges(
    params: &RasterParams,
    snapped: &[[i32; 2]],
    topology: &Topology,
    masks: &mut [u32],
    scratch: &mut ContourScratch,
    edges: EdgesStage<'_>,
) -> TriangleSummary {
    passes::<true>(params, snapped, topology, masks, scratch, edges)
}

/// [`coverage`], and with `EDGES` the `edges` stage too ([`coverage_and_edges`]).
fn passes<const EDGES: bool>(
    params: &RasterParams,
    snapped: &[[i32; 2]],
    topology: &Topology,
    masks: &mut [u32],
    scratch: &mut ContourScratch,
    edges: EdgesStage<'_>,
) -> TriangleSummary {
    let triangles = topology.triangles();
    if EDGES {
        assert_eq!(edges.orientation.len(), triangles.len(), "coverage_and_edges: one orientation per face");
    }
    scratch.signs.resize(triangles.len(), 0);
    let limit = params.width.max(params.height) as i64 * params.units as i64;
    let faces = FacePass { snapped, screen: edges.screen, limit: limit as i32 };
    let summary = faces.run::<EDGES>(triangles, &mut scratch.signs, edges.orientation);
    let grid = RowGrid::new(params);
    let (first, second) = (&mut scratch.crossings, &mut scratch.second_half);
    let edge_pass = EdgePass { grid, snapped, topology, signs: &scratch.signs, orientation: &*edges.orientation };
    let count = topology.edges().len();
    if count >= PARALLEL_EDGES {
        let mid = count / 2;
        rayon::join(
            || edge_pass.run::<EDGES>(0..mid, first, edges.candidates),
            || edge_pass.run::<EDGES>(mid..count, &mut second.0, &mut second.1),
        );
        edges.candidates.extend_from_slice(&second.1);
    } else {
        edge_pass.run::<EDGES>(0..count, first, edges.candidates);
        second.0.clear();
    }
    group_by_row(
        params,
        [&scratch.crossings[..], &scratch.second_half.0[..]],
        &mut scratch.by_row,
        &mut scratch.row_offsets,
    );
    sweep(params, &mut scratch.by_row, &scratch.row_offsets, masks, PARALLEL_CROSSINGS);
    summary
}

/// The weights `(w₊, w)` (see the module's notes) of an edge whose two faces run it opposite
/// ways ([`Topology::edge_wings`]): `f`, the sign of the face running it `a → b`, and `g`, that of
/// the face running it `b → a`.
#[inline]
pub(crate) fn wing_weights(f: i8, g: i8) -> (i32, i32) {
    let (f, g) = (f as i32, g as i32);
    ((f > 0) as i32 - (g > 0) as i32, (f != 0) as i32 - (g != 0) as i32)
}

/// The weights `(w₊, w)` (see the module's notes) of edge `e`, whose faces are not two that run
/// it opposite ways (those are in the fast path of the pass over the edges), from its faces' signs
/// (or codes, `faces::face_code`).
pub(crate) fn edge_weights(topology: &Topology, signs: &[i8], e: usize) -> (i32, i32) {
    let range = topology.edge_face_offsets()[e] as usize..topology.edge_face_offsets()[e + 1] as usize;
    let faces = &topology.edge_face_list()[range.clone()];
    let forward = &topology.edge_face_forward()[range];
    let (mut positive, mut net) = (0, 0);
    for (&face, &forward) in faces.iter().zip(forward) {
        let dir = if forward { 1 } else { -1 };
        let s = code_sign(signs[face as usize]) as i32;
        positive += dir * (s > 0) as i32;
        net += dir * (s != 0) as i32;
    }
    (positive, net)
}

/// What the crossings of an edge need of the raster.
#[derive(Clone, Copy, Debug)]
struct RowGrid {
    /// Half the sample step, in fixed-point units.
    h: i64,
    last_col: i64,
    last_row: i64,
}

impl RowGrid {
    fn new(params: &RasterParams) -> RowGrid {
        RowGrid {
            h: params.half_step as i64,
            last_col: params.width as i64 * params.supersample as i64 - 1,
            last_row: params.height as i64 * params.supersample as i64 - 1,
        }
    }

    /// Pushes the crossings of the edge `a → b` (snapped, both valid) with weights
    /// `(positive, net)` with the sample rows it spans.
    #[inline]
    fn push(&self, a: [i32; 2], b: [i32; 2], (positive, net): (i32, i32), crossings: &mut Vec<Crossing>) {
        let RowGrid { h, last_col, last_row } = *self;
        // Run the edge downwards: χ(b → a) = −χ(a → b); a horizontal edge crosses no row.
        let (top, bottom, dir) = match a[1].cmp(&b[1]) {
            std::cmp::Ordering::Less => (a, b, 1),
            std::cmp::Ordering::Greater => (b, a, -1),
            std::cmp::Ordering::Equal => return,
        };
        let (top, bottom) = ([top[0] as i64, top[1] as i64], [bottom[0] as i64, bottom[1] as i64]);
        // Rows whose sample centre (2r + 1)·h lies in [top.y, bottom.y).
        let first = (top[1] + h - 1).div_euclid(2 * h).max(0);
        let last = (bottom[1] - h - 1).div_euclid(2 * h).min(last_row);
        if first > last {
            return;
        }
        let (dx, dy) = (bottom[0] - top[0], bottom[1] - top[1]);
        // Sample column c is strictly left of the edge on row r when
        // dy·(2c + 1)·h < dx·(p.y − top.y) + dy·top.x, i.e. c ≤ ⌊(n − h·dy − 1) / (2h·dy)⌋
        // with n that right-hand side; n grows by 2h·dx from row to row.
        let m = 2 * h * dy;
        let py = (2 * first + 1) * h;
        let (mut q, mut r) = floor_div(dx * (py - top[1]) + dy * top[0] - h * dy - 1, m);
        let (dq, dr) = floor_div(2 * h * dx, m);
        let (positive, net) = (dir * positive, dir * net);
        for row in first..=last {
            if q >= 0 {
                crossings.push(Crossing { row: row as u32, last: q.min(last_col) as i32, positive, net });
            }
            q += dq;
            r += dr;
            if r >= m {
                r -= m;
                q += 1;
            }
        }
    }
}

/// The pass over the edges: the crossings of every edge with non-zero weights with the sample
/// rows it spans and, in [`coverage_and_edges`], the candidate edges.
struct EdgePass<'a> {
    grid: RowGrid,
    snapped: &'a [[i32; 2]],
    topology: &'a Topology,
    /// The faces' snapped signs, or with `CANDIDATES` their codes (`faces::face_code`).
    signs: &'a [i8],
    /// The faces' orientations (read only for the candidates).
    orientation: &'a [i8],
}

impl EdgePass<'_> {
    /// The edges `range`: their crossings into `crossings` and (with `CANDIDATES`) the candidates
    /// `(edge, side)` in edge order into `candidates` (both cleared first).
    fn run<const CANDIDATES: bool>(
        &self,
        range: std::ops::Range<usize>,
        crossings: &mut Vec<Crossing>,
        candidates: &mut Vec<(u32, i32)>,
    ) {
        crossings.clear();
        candidates.clear();
        let (signs, topology) = (self.signs, self.topology);
        let wings = &topology.edge_wings()[range.clone()];
        // The faces of most edges have equal codes (inside the silhouette or behind it): a
        // branch-free first look marks, 64 edges at a time, those whose codes differ and the
        // irregular ones (no two wings), and only those are read further.
        let last_face = signs.len().saturating_sub(1) as u32;
        for (block, wings) in wings.chunks(64).enumerate() {
            let mut marked = 0u64;
            for (i, &[f, g]) in wings.iter().enumerate() {
                let (cf, cg) = (signs[f.min(last_face) as usize], signs[g.min(last_face) as usize]);
                marked |= (((cf != cg) | (f == u32::MAX)) as u64) << i;
            }
            while marked != 0 {
                let e = range.start + 64 * block + marked.trailing_zeros() as usize;
                marked &= marked - 1;
                self.edge::<CANDIDATES>(e, crossings, candidates);
            }
        }
    }

    /// Edge `e`, whose faces' codes differ or which is irregular: its crossings and (with
    /// `CANDIDATES`) whether it is a candidate.
    #[inline(always)]
    fn edge<const CANDIDATES: bool>(&self, e: usize, crossings: &mut Vec<Crossing>, candidates: &mut Vec<(u32, i32)>) {
        let (signs, orientation, topology) = (self.signs, self.orientation, self.topology);
        let [f, g] = topology.edge_wings()[e];
        let weights = if f != u32::MAX {
            // The usual edge: face f runs it a → b, face g b → a. Equal signs cancel; it is a
            // candidate exactly when the orientations differ (see `edges`).
            let (sf, sg) = (code_sign(signs[f as usize]), code_sign(signs[g as usize]));
            if CANDIDATES {
                let (of, og) = (orientation[f as usize], orientation[g as usize]);
                if of != og {
                    candidates.push((e as u32, (of as i32 - og as i32).signum()));
                }
            }
            if sf == sg {
                return;
            }
            wing_weights(sf, sg)
        } else {
            if CANDIDATES {
                let side = edge_side(orientation, topology, e);
                if side != 0 {
                    candidates.push((e as u32, side));
                }
            }
            match edge_weights(topology, signs, e) {
                (0, 0) => return,
                weights => weights,
            }
        };
        // A face with non-zero sign has valid vertices, so both ends are valid.
        let [a, b] = topology.edges()[e].map(|v| self.snapped[v as usize]);
        self.grid.push(a, b, weights, crossings);
    }
}

/// Groups the crossings of both lists by sample row (a counting sort): `by_row` and its
/// `row_offsets`.
fn group_by_row(
    params: &RasterParams,
    lists: [&[Crossing]; 2],
    by_row: &mut Vec<Crossing>,
    row_offsets: &mut Vec<u32>,
) {
    let crossings = || lists.iter().flat_map(|list| list.iter());
    let rows = (params.height * params.supersample) as usize;
    row_offsets.clear();
    row_offsets.resize(rows + 1, 0);
    for c in crossings() {
        row_offsets[c.row as usize + 1] += 1;
    }
    for r in 0..rows {
        row_offsets[r + 1] += row_offsets[r];
    }
    by_row.resize(row_offsets[rows] as usize, Crossing::default());
    // Place with `row_offsets[r]` as row r's cursor: it ends at row r + 1's start...
    for c in crossings() {
        let slot = &mut row_offsets[c.row as usize];
        by_row[*slot as usize] = *c;
        *slot += 1;
    }
    // ...so shifting the cursors up by one row gives the starts back.
    for r in (1..=rows).rev() {
        row_offsets[r] = row_offsets[r - 1];
    }
    row_offsets[0] = 0;
}

/// Sets the covered samples of every row from its crossings (the masks are cleared first),
/// halving the rows into parallel tasks while a task has `parallel_from` crossings or more.
fn sweep(params: &RasterParams, by_row: &mut [Crossing], row_offsets: &[u32], masks: &mut [u32], parallel_from: usize) {
    sweep_rows(params, (0, params.height as usize), by_row, row_offsets, masks, parallel_from);
}

/// [`sweep`] for pixel rows `rows.0..rows.1`, whose mask words are `masks` and crossings `by_row`.
/// Rows are independent: with many crossings the rows are halved and the halves swept in
/// parallel.
fn sweep_rows(
    params: &RasterParams,
    rows: (usize, usize),
    by_row: &mut [Crossing],
    row_offsets: &[u32],
    masks: &mut [u32],
    parallel_from: usize,
) {
    let f = params.supersample as usize;
    if by_row.len() >= parallel_from && rows.1 - rows.0 >= 2 {
        let mid = (rows.0 + rows.1) / 2;
        let row_words = params.width as usize * params.words_per_pixel as usize;
        let (masks_a, masks_b) = masks.split_at_mut((mid - rows.0) * row_words);
        let split = (row_offsets[mid * f] - row_offsets[rows.0 * f]) as usize;
        let (by_row_a, by_row_b) = by_row.split_at_mut(split);
        rayon::join(
            || sweep_rows(params, (rows.0, mid), by_row_a, row_offsets, masks_a, parallel_from),
            || sweep_rows(params, (mid, rows.1), by_row_b, row_offsets, masks_b, parallel_from),
        );
        return;
    }
    masks.fill(0);
    let mut band = Band::new(params, masks, rows.0 as i64);
    let base = row_offsets[rows.0 * f];
    for row in rows.0 * f..rows.1 * f {
        let list = &mut by_row[(row_offsets[row] - base) as usize..(row_offsets[row + 1] - base) as usize];
        if !list.is_empty() {
            sweep_row(row as i64, list, &mut band);
        }
    }
}

/// One sample row: sorts its crossings by column and sets the spans where `N₊ > min(0, D)`.
#[inline]
fn sweep_row(row: i64, crossings: &mut [Crossing], band: &mut Band<'_>) {
    crossings.sort_unstable_by_key(|c| std::cmp::Reverse(c.last));
    // From the right: columns after a crossing's `last` do not have it in their sums.
    let (mut positive, mut net) = (0, 0);
    let mut k = 0;
    let mut span_end: Option<i64> = None; // last column of the covered span being swept
    while k < crossings.len() {
        let last = crossings[k].last;
        while k < crossings.len() && crossings[k].last == last {
            positive += crossings[k].positive;
            net += crossings[k].net;
            k += 1;
        }
        // Columns (next crossing's last, last] have these sums.
        let covered = positive > net.min(0);
        match (covered, span_end) {
            (true, None) => span_end = Some(last as i64),
            (false, Some(end)) => {
                band.set_span(row, (last as i64 + 1, end));
                span_end = None;
            }
            _ => {}
        }
    }
    if let Some(end) = span_end {
        band.set_span(row, (0, end));
    }
}

mod faces;
#[cfg(test)]
mod tests;

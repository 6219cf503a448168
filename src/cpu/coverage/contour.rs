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

use rayon::prelude::*;

use super::bands::Band;
use super::setup::{TriangleSummary, BLOCK};
use super::triangle::floor_div;
use crate::cpu::bin::CULLED_BOX;
use crate::mirror::{RasterParams, INVALID_SNAPPED};
use crate::scene::mesh::Topology;

/// Triangles per parallel task of [`face_signs`].
const FACES_PER_TASK: usize = 16384;

/// Crossings from which the sweep splits its rows into halves swept in parallel.
const PARALLEL_CROSSINGS: usize = 16384;

/// The buffers of [`coverage`], kept from forward to forward.
#[derive(Clone, Debug, Default)]
pub struct ContourScratch {
    /// The sign of every face's snapped area (0: a clipped vertex or zero area).
    signs: Vec<i8>,
    /// Crossings in the order the edges produce them.
    crossings: Vec<Crossing>,
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
/// writes `masks` (`pixel_count · words_per_pixel` words) and, on the way, every triangle's
/// snapped box into `boxes` (as [`bin::snapped_boxes`](crate::cpu::bin::snapped_boxes) computes
/// them; the backward bins from them without reading the vertices again), and returns the
/// summary the `bin` stage's tile size is chosen from. `scratch` keeps the pass's buffers from
/// call to call.
pub fn coverage(
    params: &RasterParams,
    snapped: &[[i32; 2]],
    topology: &Topology,
    boxes: &mut [[i32; 4]],
    masks: &mut [u32],
    scratch: &mut ContourScratch,
) -> TriangleSummary {
    let triangles = topology.triangles();
    scratch.signs.resize(triangles.len(), 0);
    let limit = params.width.max(params.height) as i64 * params.units as i64;
    let summary = face_signs(snapped, triangles, limit, &mut scratch.signs, boxes);
    crossings(params, snapped, topology, &scratch.signs, &mut scratch.crossings);
    group_by_row(params, &scratch.crossings, &mut scratch.by_row, &mut scratch.row_offsets);
    sweep(params, &mut scratch.by_row, &scratch.row_offsets, masks, PARALLEL_CROSSINGS);
    summary
}

/// Every face's snapped box (into `boxes`, [`CULLED_BOX`] for a clipped one) and the sign of its
/// snapped area (into `signs`), and the summary of [`coverage`]: one pass over
/// the faces in blocks of eight, in parallel tasks for a large mesh.
fn face_signs(
    snapped: &[[i32; 2]],
    triangles: &[[u32; 3]],
    limit: i64,
    signs: &mut [i8],
    boxes: &mut [[i32; 4]],
) -> TriangleSummary {
    if triangles.len() <= FACES_PER_TASK {
        return face_signs_of_chunk(snapped, triangles, limit, signs, boxes);
    }
    triangles
        .par_chunks(FACES_PER_TASK)
        .zip(signs.par_chunks_mut(FACES_PER_TASK))
        .zip(boxes.par_chunks_mut(FACES_PER_TASK))
        .map(|((tris, signs), boxes)| face_signs_of_chunk(snapped, tris, limit, signs, boxes))
        .reduce(TriangleSummary::default, |a, b| a + b)
}

/// [`face_signs`] of one task's faces.
fn face_signs_of_chunk(
    snapped: &[[i32; 2]],
    triangles: &[[u32; 3]],
    limit: i64,
    signs: &mut [i8],
    boxes: &mut [[i32; 4]],
) -> TriangleSummary {
    let mut summary = TriangleSummary::default();
    let mut tris = triangles.chunks_exact(BLOCK);
    let mut sign_blocks = signs.chunks_exact_mut(BLOCK);
    let mut box_blocks = boxes.chunks_exact_mut(BLOCK);
    for ((t, s), b) in (&mut tris).zip(&mut sign_blocks).zip(&mut box_blocks) {
        let t: &[[u32; 3]; BLOCK] = t.try_into().expect("a whole block");
        face_block(snapped, t, limit as i32, s, b, &mut summary);
    }
    let rest = tris.remainder();
    if let Some(&last) = rest.last() {
        // A short block: the missing lanes repeat the last face; only `rest.len()` are written.
        let mut padded = [last; BLOCK];
        padded[..rest.len()].copy_from_slice(rest);
        face_block(
            snapped,
            &padded,
            limit as i32,
            sign_blocks.into_remainder(),
            box_blocks.into_remainder(),
            &mut summary,
        );
    }
    summary
}

/// One block of [`face_signs`]: lanes computed branch-free, the first `signs.len()` written.
#[inline(always)]
fn face_block(
    snapped: &[[i32; 2]],
    tris: &[[u32; 3]; BLOCK],
    limit: i32,
    signs: &mut [i8],
    boxes: &mut [[i32; 4]],
    summary: &mut TriangleSummary,
) {
    let (mut x, mut y) = ([[0i32; BLOCK]; 3], [[0i32; BLOCK]; 3]);
    for (l, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let p = snapped[t[k] as usize];
            (x[k][l], y[k][l]) = (p[0], p[1]);
        }
    }
    let (mut lo_x, mut lo_y, mut hi_x, mut hi_y) = ([0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK]);
    let (mut extent, mut valid, mut wide) = ([0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK]);
    let (mut ax, mut ay, mut bx, mut by) = ([0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK]);
    for l in 0..BLOCK {
        let ok = !((x[0][l] == INVALID_SNAPPED) | (x[1][l] == INVALID_SNAPPED) | (x[2][l] == INVALID_SNAPPED)) as i32;
        let b = [
            x[0][l].min(x[1][l]).min(x[2][l]),
            y[0][l].min(y[1][l]).min(y[2][l]),
            x[0][l].max(x[1][l]).max(x[2][l]),
            y[0][l].max(y[1][l]).max(y[2][l]),
        ];
        extent[l] = b[2].wrapping_sub(b[0]).max(b[3].wrapping_sub(b[1])).min(limit) & -ok;
        // CULLED_BOX for a clipped lane, branch-free: ok is 0 or 1, so −ok is 0 or −1.
        lo_x[l] = (b[0] & -ok) | (CULLED_BOX[0] & (ok - 1));
        lo_y[l] = (b[1] & -ok) | (CULLED_BOX[1] & (ok - 1));
        hi_x[l] = (b[2] & -ok) | (CULLED_BOX[2] & (ok - 1));
        hi_y[l] = (b[3] & -ok) | (CULLED_BOX[3] & (ok - 1));
        valid[l] = ok;
        // Edge vectors (valid coordinates are within ±2^29, so these fit in i32; a clipped
        // lane's may wrap: it is masked out).
        ax[l] = x[1][l].wrapping_sub(x[0][l]);
        ay[l] = y[1][l].wrapping_sub(y[0][l]);
        bx[l] = x[2][l].wrapping_sub(x[0][l]);
        by[l] = y[2][l].wrapping_sub(y[0][l]);
        // Whether a difference reaches 2^26 (the f64 area below is exact under it).
        let reach = |d: i32| (d.wrapping_add(1 << 26) as u32 >= 1 << 27) as i32;
        wide[l] = (reach(ax[l]) | reach(ay[l]) | reach(bx[l]) | reach(by[l])) & ok;
    }
    // The sign of the snapped area: in f64, exact while every difference is below 2^26 (products
    // below 2^52, their difference below 2^53); in i64 for a block with a wider one.
    let mut sign = [0i8; BLOCK];
    if wide.iter().all(|&w| w == 0) {
        for l in 0..BLOCK {
            let area2 = ax[l] as f64 * by[l] as f64 - ay[l] as f64 * bx[l] as f64;
            sign[l] = (((area2 > 0.0) as i8) - ((area2 < 0.0) as i8)) * valid[l] as i8;
        }
    } else {
        for l in 0..BLOCK {
            let area2 = ax[l] as i64 * by[l] as i64 - ay[l] as i64 * bx[l] as i64;
            sign[l] = (((area2 > 0) as i8) - ((area2 < 0) as i8)) * valid[l] as i8;
        }
    }
    let n = signs.len();
    signs.copy_from_slice(&sign[..n]);
    for (l, out) in boxes.iter_mut().enumerate() {
        *out = [lo_x[l], lo_y[l], hi_x[l], hi_y[l]];
    }
    let counted: i32 = valid[..n].iter().sum();
    summary.culled += (n as i32 - counted) as u32;
    summary.counted += counted as u64;
    summary.extent_sum += extent[..n].iter().map(|&e| e as u64).sum::<u64>();
}

/// The weights `(w₊, w)` (see the module's notes) of edge `e`, whose faces are not two that run
/// it opposite ways (those are in [`crossings`]' fast path), from its faces' signs.
fn edge_weights(topology: &Topology, signs: &[i8], e: usize) -> (i32, i32) {
    let range = topology.edge_face_offsets()[e] as usize..topology.edge_face_offsets()[e + 1] as usize;
    let faces = &topology.edge_face_list()[range.clone()];
    let forward = &topology.edge_face_forward()[range];
    let (mut positive, mut net) = (0, 0);
    for (&face, &forward) in faces.iter().zip(forward) {
        let dir = if forward { 1 } else { -1 };
        let s = signs[face as usize] as i32;
        positive += dir * (s > 0) as i32;
        net += dir * (s != 0) as i32;
    }
    (positive, net)
}

/// The crossings of every edge with non-zero weights with the sample rows it spans, into
/// `crossings` (cleared first).
fn crossings(
    params: &RasterParams,
    snapped: &[[i32; 2]],
    topology: &Topology,
    signs: &[i8],
    crossings: &mut Vec<Crossing>,
) {
    crossings.clear();
    let h = params.half_step as i64;
    let last_col = params.width as i64 * params.supersample as i64 - 1;
    let last_row = params.height as i64 * params.supersample as i64 - 1;
    let edges = topology.edges();
    for (e, &[f, g]) in topology.edge_wings().iter().enumerate() {
        let (positive, net) = if f != u32::MAX {
            // The usual edge: face f runs it a → b, face g b → a. Equal signs cancel (most
            // edges: inside the silhouette or behind it).
            let (f, g) = (signs[f as usize], signs[g as usize]);
            if f == g {
                continue;
            }
            let (f, g) = (f as i32, g as i32);
            ((f > 0) as i32 - (g > 0) as i32, (f != 0) as i32 - (g != 0) as i32)
        } else {
            match edge_weights(topology, signs, e) {
                (0, 0) => continue,
                weights => weights,
            }
        };
        // A face with non-zero sign has valid vertices, so both ends are valid.
        let [a, b] = edges[e].map(|v| snapped[v as usize]);
        // Run the edge downwards: χ(b → a) = −χ(a → b); a horizontal edge crosses no row.
        let (top, bottom, dir) = match a[1].cmp(&b[1]) {
            std::cmp::Ordering::Less => (a, b, 1),
            std::cmp::Ordering::Greater => (b, a, -1),
            std::cmp::Ordering::Equal => continue,
        };
        let (top, bottom) = ([top[0] as i64, top[1] as i64], [bottom[0] as i64, bottom[1] as i64]);
        // Rows whose sample centre (2r + 1)·h lies in [top.y, bottom.y).
        let first = (top[1] + h - 1).div_euclid(2 * h).max(0);
        let last = (bottom[1] - h - 1).div_euclid(2 * h).min(last_row);
        if first > last {
            continue;
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

/// Groups the crossings by sample row (a counting sort): `by_row` and its `row_offsets`.
fn group_by_row(params: &RasterParams, crossings: &[Crossing], by_row: &mut Vec<Crossing>, row_offsets: &mut Vec<u32>) {
    let rows = (params.height * params.supersample) as usize;
    row_offsets.clear();
    row_offsets.resize(rows + 1, 0);
    for c in crossings {
        row_offsets[c.row as usize + 1] += 1;
    }
    for r in 0..rows {
        row_offsets[r + 1] += row_offsets[r];
    }
    by_row.resize(crossings.len(), Crossing::default());
    // Place with `row_offsets[r]` as row r's cursor: it ends at row r + 1's start...
    for c in crossings {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::coverage::{draw_triangles, xorshift, BackFaceSkip};
    use crate::mirror::{ScreenVertex, COORD_LIMIT, INVALID_SNAPPED_VERTEX};

    /// The masks, boxes and summary of [`coverage`] and of drawing the triangles.
    fn both(
        params: &RasterParams,
        snapped: &[[i32; 2]],
        topology: &Topology,
    ) -> [(Vec<u32>, Vec<[i32; 4]>, TriangleSummary); 2] {
        let n = topology.triangles().len();
        let words = params.pixel_count() * params.words_per_pixel as usize;
        let (mut masks, mut boxes) = (vec![0u32; words], vec![[0; 4]; n]);
        let skip = BackFaceSkip::new(topology, snapped);
        let drawn = draw_triangles(params, snapped, topology.triangles(), skip.as_ref(), &mut boxes, &mut masks);
        let a = (masks, boxes, drawn);
        // Stale contents in the outputs and the scratch must not matter.
        let (mut masks, mut boxes) = (vec![u32::MAX; words], vec![[7; 4]; n]);
        let mut scratch = ContourScratch::default();
        for _ in 0..2 {
            coverage(params, snapped, topology, &mut boxes, &mut masks, &mut scratch);
        }
        let filled = coverage(params, snapped, topology, &mut boxes, &mut masks, &mut scratch);
        [a, (masks, boxes, filled)]
    }

    /// `(g, s, t)` with `a·s + b·t = g = gcd(a, b)`.
    fn extended_gcd(a: i64, b: i64) -> (i64, i64, i64) {
        if b == 0 {
            (a.abs(), a.signum(), 0)
        } else {
            let (g, s, t) = extended_gcd(b, a.rem_euclid(b));
            (g, t, s - a.div_euclid(b) * t)
        }
    }

    /// Face signs and boxes against i64 areas and `bin::snapped_boxes`, for coordinates of every
    /// size (blocks on the f64 path, differences below 2^26, and on the i64 one above it),
    /// slivers of snapped area ±1 unit² whose two products are about 2^6, 2^46 or 2^54, clipped
    /// vertices, and every length of the last block.
    #[test]
    fn face_signs_are_exact() {
        let mut rand = xorshift(0x2545_f491_4f6c_dd1d);
        for n in (0..=2 * BLOCK + 1).chain([100, 3 * FACES_PER_TASK + 5]) {
            let mut snapped = Vec::new();
            for k in 0..n {
                // One size per block, so that whole blocks take each path.
                let scale = [1 << 10, 1 << 24, 1 << 28][k / BLOCK % 3] as f64;
                let mut coord = || ((rand() - 0.5) * scale) as i64;
                let v0 = [coord(), coord()];
                let mut v: [[i64; 2]; 3] = [v0, [coord(), coord()], [coord(), coord()]];
                if k % 2 == 1 {
                    // A sliver: v2 − v0 = b + d with cross(d, b) = ±1, d = v1 − v0 (gcd 1).
                    // |d| of at least half the scale, so that the top size's products exceed 2^53.
                    let mut half = |sign: bool| (scale * (0.5 + 0.25 * rand())) as i64 * if sign { 1 } else { -1 };
                    let mut d = [half(k % 3 == 0), half(k % 5 < 2)];
                    while extended_gcd(d[0], d[1]).0 != 1 {
                        d[0] += 1;
                    }
                    let (_, s, t) = extended_gcd(d[0], d[1]);
                    let flip = if k % 4 == 1 { 1 } else { -1 };
                    let b = [-t * flip, s * flip];
                    v[1] = [v0[0] + d[0], v0[1] + d[1]];
                    v[2] = [v0[0] + b[0] + d[0], v0[1] + b[1] + d[1]];
                }
                let mut v = v.map(|p| [p[0] as i32, p[1] as i32]);
                if k % 9 == 4 && k / BLOCK % 4 == 3 {
                    v[k % 3] = INVALID_SNAPPED_VERTEX;
                }
                snapped.extend(v);
            }
            let triangles: Vec<[u32; 3]> = (0..n as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
            let (mut signs, mut boxes) = (vec![9i8; n], vec![[5; 4]; n]);
            face_signs(&snapped, &triangles, 1 << 20, &mut signs, &mut boxes);
            assert_eq!(boxes, crate::cpu::bin::snapped_boxes(&snapped, &triangles), "n = {n}");
            for (k, t) in triangles.iter().enumerate() {
                let v = t.map(|i| snapped[i as usize]);
                let expected = if v.contains(&INVALID_SNAPPED_VERTEX) {
                    0
                } else {
                    let w = v.map(|p| [p[0] as i64, p[1] as i64]);
                    let area2 = crate::cpu::coverage::triangle::area2(&w);
                    if k % 2 == 1 {
                        assert_eq!(area2.abs(), 1, "the sliver's area");
                    }
                    area2.signum() as i8
                };
                assert_eq!(signs[k], expected, "n = {n}, face {k}: {v:?}");
            }
        }
    }

    /// Closed meshes, meshes with holes, flipped faces and open patches, under random (folded)
    /// 2D placements with many exact ties on sample positions: the same masks, boxes and summary.
    #[test]
    fn contour_fill_matches_drawing_on_meshes() {
        let mut rand = xorshift(0x5851_f42d_4c95_7f2d);
        let sphere = crate::scene::shapes::icosphere(3);
        let closed = sphere.triangles().to_vec();
        let mut covered_some = false;
        for case in 0..160 {
            let mut triangles = closed.clone();
            match case % 5 {
                0 => {}
                1 => triangles.retain(|_| rand() > 0.05),
                2 => triangles.iter_mut().filter(|_| rand() < 0.03).for_each(|t| t.swap(1, 2)),
                3 => triangles.truncate(triangles.len() / 2),
                _ => {
                    // Non-manifold: some faces repeated, some repeated flipped, some degenerate.
                    let extra: Vec<[u32; 3]> = triangles.iter().filter(|_| rand() < 0.05).copied().collect();
                    triangles.extend(extra.iter().map(|t| [t[0], t[2], t[1]]));
                    triangles.extend(extra.iter().take(20));
                    triangles.extend(extra.iter().take(10).map(|t| [t[0], t[0], t[1]]));
                }
            }
            let f = [1, 2, 3, 4, 5, 6][case % 6];
            let (w, h) = (23 + case as u32 % 9, 17 + case as u32 % 5);
            let params = RasterParams::new(w, h, f, 1.0, 0.0).unwrap();
            let topology = Topology::new(sphere.positions().len(), triangles).unwrap();
            let m = [rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand(), rand()];
            let grid = 2.0 * f as f64;
            let scale = [0.45, 0.45, 0.2, 1.5][case % 4];
            let mut snapped: Vec<[i32; 2]> = sphere
                .positions()
                .iter()
                .map(|p| {
                    let (x, y) = (p.x as f64, p.y as f64 + m[5] * p.z as f64);
                    let noise = if case % 3 == 0 { 0.0 } else { 0.6 };
                    let sx = w as f64 * (0.5 + scale * (m[0] * x + m[1] * y)) + noise * (rand() - 0.5);
                    let sy = h as f64 * (0.5 + scale * (m[2] * x + m[3] * y)) + noise * (rand() - 0.5);
                    let q = |c: f64| ((c * grid).round() / grid) as f32;
                    params.snap_vertex(&ScreenVertex { position: [q(sx), q(sy)], valid: 1, pad: 0 })
                })
                .collect();
            if case % 7 == 3 {
                // Clipped vertices: their faces are culled.
                for v in snapped.iter_mut().filter(|_| rand() < 0.02) {
                    *v = INVALID_SNAPPED_VERTEX;
                }
            }
            let [drawn, filled] = both(&params, &snapped, &topology);
            assert_eq!(drawn.1, filled.1, "case {case}: boxes");
            assert_eq!(drawn.2, filled.2, "case {case}: summary");
            assert_eq!(drawn.0, filled.0, "case {case}: masks");
            covered_some |= drawn.0.iter().any(|&m| m != 0) && drawn.0.contains(&0);
        }
        assert!(covered_some);
    }

    /// Triangle soups (no shared edges), large triangles with vertices far off the image and at
    /// the coordinate limit, and slivers: the same masks.
    #[test]
    fn contour_fill_matches_drawing_on_soups() {
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
        let mut rand = move || next() as f32;
        for case in 0..40 {
            let (f, w, h) = [(4, 13, 9), (3, 10, 12), (1, 17, 5), (7, 8, 8)][case % 4];
            let params = RasterParams::new(w, h, f, 1.0, 0.0).unwrap();
            let n = [1, 7, 60, 400][case % 4];
            let mut screen = Vec::new();
            for k in 0..n {
                let c = [rand() * (w as f32 + 6.0) - 3.0, rand() * (h as f32 + 6.0) - 3.0];
                let size = [0.3, 1.5, 6.0, 40.0][k % 4];
                for j in 0..3 {
                    let mut p = [c[0] + (rand() - 0.5) * size, c[1] + (rand() - 0.5) * size];
                    if k % 11 == 5 && j == 1 {
                        p[0] = (COORD_LIMIT - 1.0) * if k % 2 == 0 { 1.0 } else { -1.0 };
                    }
                    if k % 17 == 3 && j == 2 {
                        p[1] = -(COORD_LIMIT - 1.0);
                    }
                    if k % 5 == 4 {
                        p = p.map(|c| (c * 2.0 * f as f32).round() / (2.0 * f as f32));
                    }
                    screen.push(ScreenVertex { position: p, valid: (k % 13 != 7 || j != 2) as u32, pad: 0 });
                }
            }
            let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
            let triangles: Vec<[u32; 3]> = (0..n as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
            let topology = Topology::new(snapped.len(), triangles).unwrap();
            let [drawn, filled] = both(&params, &snapped, &topology);
            assert_eq!(drawn, filled, "case {case}");
        }
    }

    /// Large meshes take the parallel paths (faces in tasks, rows in halves): the same masks as
    /// drawing, at several resolutions.
    #[test]
    fn contour_fill_matches_drawing_in_parallel() {
        let sphere = crate::scene::shapes::icosphere(6);
        assert!(sphere.triangles().len() > 2 * FACES_PER_TASK);
        for (res, f) in [(16, 4), (200, 4), (300, 3)] {
            let params = RasterParams::new(res, res, f, 1.0, 0.0).unwrap();
            let snapped: Vec<[i32; 2]> = sphere
                .positions()
                .iter()
                .map(|p| {
                    let s = res as f32 * 0.4;
                    let q = [res as f32 / 2.0 + s * (p.x + 0.3 * p.z), res as f32 / 2.0 - s * (p.y + 0.2 * p.x * p.x)];
                    params.snap_vertex(&ScreenVertex { position: q, valid: 1, pad: 0 })
                })
                .collect();
            let [drawn, filled] = both(&params, &snapped, sphere.topology());
            assert_eq!(drawn, filled, "{res}² F={f}");
            // The rows halved down to single rows: the same masks.
            let mut scratch = ContourScratch::default();
            let (mut boxes, mut masks) = (vec![[0; 4]; sphere.triangles().len()], vec![u32::MAX; drawn.0.len()]);
            coverage(&params, &snapped, sphere.topology(), &mut boxes, &mut masks, &mut scratch);
            masks.fill(u32::MAX);
            sweep(&params, &mut scratch.by_row, &scratch.row_offsets, &mut masks, 1);
            assert_eq!(drawn.0, masks, "{res}² F={f}, rows in parallel halves");
        }
    }
}

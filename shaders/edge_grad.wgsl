// `edge_grad` — twin of `cpu::edge_grad::edge_grad` (src/cpu/edge_grad.rs): per candidate edge of
// every view, the analytic derivative of the loss with respect to its two endpoints, over the
// pixels it crosses, visible parts only.
//
// Reads:  `frame`, `screen`, `edges`, `bins` (the tile lists' CSR offsets and triangle indices), `occluders` (the
//         occluder record of every entry of the tile lists and large-triangle lists), `classes`
//         (edge sides, the candidate list), `d_image` (∂L/∂I of all views, concatenated like the
//         images), `status` (list lengths).
// Writes: `partials[k · parts + p]` = (Σ g·∫(1 − s), Σ g·∫ s) over part p of candidate k
//         (parts = `status[STATUS_PARTS]`, shared/parts.wgsl), as two
//         float-float numbers — each item's slot written once, no float atomics;
//         `status[status_index(view, STATUS_SEGMENTS / STATUS_VISIBLE)]` and
//         `status[STATUS_MAX_ITERATIONS]` (integer counts, atomic).
//         `edge_faces` (an edge's faces, for its rank among coincident edges).
// Dispatch: 1D over candidates · parts work items, ITEMS (2) per workgroup of LANES (64)
//         invocations; `edge_sum` then adds the parts of each edge in order and applies the
//         outward normal.
//
// Part p of an edge covers the pixels whose coordinate along the edge's major axis lies in
// [start + Lp, start + Lp + L), L = `part_length(tile_size)` (4 to 16), from the edge's own first
// pixel line `start` (shared/parts.wgsl): at most ~2L + 1 pixels, so no workgroup runs long (a
// 1000-pixel edge is 63 parts in parallel), and every pixel of the edge belongs to exactly one
// part. The frame has as many parts per candidate as its longest candidate needs (`edges` counts
// them): one or two for a dense mesh. Small tiles (dense meshes) get short parts: their pixels
// hold many occluders.
//
// A workgroup takes its items that cross a pixel one after another, all 64 lanes together: they
// walk the item's pixels in step and split each pixel's occluder scan between them, entry k to
// lane k mod 64 (a pixel of a dense mesh lists dozens to thousands of triangles: scanned by one
// invocation, that list was the critical path of the whole stage on a GPU).
//
// Per pixel: the scanline DDA of the CPU (rows the segment spans, columns within each row),
// Liang–Barsky clipping to the pixel, ½ weight for a segment lying on a pixel border, then the
// visible parts: every triangle listed in the pixel's tile (and in its view's large list) gives
// the parameter interval where the point just outside the edge (+ε·outward) is inside it, and the
// closed form is applied to the complement of their union. As on the CPU, the intervals are
// sorted by start (`sort_intervals`, the lanes ranking them in workgroup memory) and merged in one
// pass (`merge_sorted`, lane 0, which writes the item's results), so the gaps are summed in
// increasing order whatever the order of the tile lists or of the lanes' appends: deterministic.
// A pixel with more than SHARED (64) intervals is swept from the lists instead
// (`visible_weights`, same gaps, O(n · list length) on lane 0 alone: slow, and rare).
//
// Precision: the CPU computes in f64. Here every clip parameter, occlusion bound and gap length
// is computed in float-float arithmetic (shared/ff.wgsl, ~44 bits) from differences of the f32
// inputs taken exactly, so a long edge's per-pixel weights keep their relative accuracy (plain
// f32 parameters would be off by ~1e-7 of the edge length). The discrete decisions use exact
// values: face orientations come from `classes` (the CPU's f64 signs, reproduced exactly), and
// cross products vanish exactly for shared and coincident vertices (`ff_cross`), so a face
// adjacent to the edge never occludes it.
//
// Coincident edges (the CPU's `occluded_interval`): a triangle with an edge on the candidate's
// line, lying on the candidate's inside, covers none of its outside, but when it ranks before the
// candidate (its index below that of the candidate's lowest face with a non-zero orientation, `Edge.rank`) its edge carries that
// stretch and the candidate leaves it out, so coincident edges move the area once. Per-pixel weights are f32 (relative error ~1e-7) and
// are summed in float-float.

//!include shared/frame.wgsl
//!include shared/ff.wgsl
//!include shared/dispatch.wgsl
//!include shared/parts.wgsl

@group(0) @binding(1) var<storage, read> screen: array<ScreenVertex>;
// Occluder records beside the bin list entries (shared/tiles.wgsl, `occluder_record`).
@group(0) @binding(2) var<storage, read> occluders: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> edges: array<u32>;
@group(0) @binding(4) var<storage, read> bins: array<u32>;
@group(0) @binding(5) var<storage, read> classes: array<i32>;
@group(0) @binding(6) var<storage, read> d_image: array<f32>;
@group(0) @binding(7) var<storage, read_write> partials: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;
// The indirect dispatch of `main` in a fused step (written by `args`).
@group(0) @binding(9) var<storage, read_write> dispatch_args: array<u32, 3>;
// Edge → faces CSR (offsets [0 ..= edge_count], then the face lists, each in increasing order).
@group(0) @binding(10) var<storage, read> edge_faces: array<u32>;

// Reads:  `frame` (partial_capacity, max_workgroups), `status` (the candidate and part counts).
// Writes: `dispatch_args`: the workgroup grid of `main` for candidates × parts work items (ITEMS
//         per workgroup, tiled like `workgroup_grid` in src/gpu/mod.rs), or an empty grid and
//         `status[STATUS_PARTIALS_SHORT]` = 1 when they exceed `partial_capacity` (the host then
//         grows the buffer and runs the backward on its own).
// Dispatch: one invocation, in a fused step (forward, loss and backward in one submission),
//         between `edges` and `main`.
@compute @workgroup_size(1)
fn args() {
    let parts = max(atomicLoad(&status[STATUS_PARTS]), 1u);
    let candidates = atomicLoad(&status[STATUS_CANDIDATE_TOTAL]);
    dispatch_args = array<u32, 3>(0u, 1u, 1u);
    if candidates > frame.params.partial_capacity / parts {
        atomicStore(&status[STATUS_PARTIALS_SHORT], 1u);
        return;
    }
    let groups = (candidates * parts + ITEMS - 1u) / ITEMS;
    if groups == 0u {
        return;
    }
    let limit = max(frame.params.max_workgroups, 1u);
    let y = (groups + limit - 1u) / limit;
    dispatch_args = array<u32, 3>((groups + y - 1u) / y, y, 1u);
}

// Work items (candidate × part) per workgroup. The workgroup's first ITEMS lanes find which of its
// items cross a pixel; then all LANES lanes take those items one after another, together: they
// walk the item's pixels in step and scan each pixel's occluder lists LANES entries at a time.
// (2: with one or two parts per candidate, a dense mesh's items fit about one wave of workgroups
// on a large GPU; not yet tuned on hardware.)
const ITEMS: u32 = EDGE_GRAD_ITEMS_PER_WORKGROUP;
const LANES: u32 = 64u;
// Intervals of one pixel kept in workgroup memory; past that they are recomputed from the lists.
const SHARED: u32 = 64u;
const NO_ITEM: u32 = 0xffffffffu;

// The workgroup's items that cross a pixel (NO_ITEM for the others), each with the length of its
// view's large-triangle list.
var<workgroup> wg_items: array<vec2<u32>, ITEMS>;
// `status[STATUS_PARTS]`, for `workgroupUniformLoad`.
var<workgroup> wg_parts: u32;
// An interval [lo, hi] of float-float parameters: (lo.hi, lo.lo, hi.hi, hi.lo); empty when
// hi ≤ lo. A pixel's non-empty intervals as the lanes found them, then sorted by start.
var<workgroup> wg_intervals: array<vec4<f32>, SHARED>;
var<workgroup> wg_sorted: array<vec4<f32>, SHARED>;
// Running counts over the workgroup's pixels (from 0: workgroup memory starts zeroed): intervals
// found, and intervals that cover the whole segment in their pixel (which is then hidden). A pixel's scan adds to them; every lane reads
// them between the two barriers that follow (the next pixel's scan starts after the second), and
// lane 0 merges `wg_sorted` before it reaches the next pixel's first barrier, after which the
// lanes sort into it again.
var<workgroup> wg_found: atomic<u32>;
var<workgroup> wg_hiding: atomic<u32>;
// Loop iterations of this invocation (see `stages::LLVMPIPE_LOOP_LIMIT`). llvmpipe runs 8
// invocations as one SIMD batch whose loops run as long as the longest lane's, and the lanes'
// loops may interleave, so 8 × an invocation's count bounds its batch: past an eighth of the
// frame's loop budget (llvmpipe only; no limit elsewhere) the invocation stops and reports it, so
// that the host fails instead of returning a silently truncated result.
var<private> iterations: u32;
var<private> exhausted: bool;

// Counts one loop iteration; false (and `exhausted`) past the budget.
fn tick() -> bool {
    iterations += 1u;
    exhausted = exhausted || (frame.params.loop_budget != 0u && iterations > frame.params.loop_budget / 8u);
    return !exhausted;
}

fn iv_empty(iv: vec4<f32>) -> bool {
    return ff_le(iv.zw, iv.xy);
}

// Liang–Barsky step (`closed_form::clip_parameter`): narrows s = (s0, s1) so that
// p0 + t·d ∈ [lo, hi].
fn clip_parameter(p0: f32, d: vec2<f32>, lo: f32, hi: f32, s: ptr<function, vec4<f32>>) -> bool {
    if ff_is_zero(d) {
        return lo <= p0 && p0 <= hi;
    }
    var t0 = ff_div(ff_diff(lo, p0), d);
    var t1 = ff_div(ff_diff(hi, p0), d);
    if d.x < 0.0 {
        let t = t0;
        t0 = t1;
        t1 = t;
    }
    let s0 = ff_max((*s).xy, t0);
    let s1 = ff_min((*s).zw, t1);
    *s = vec4<f32>(s0, s1);
    return ff_le(s0, s1);
}

// [∫(1 − s) ds, ∫ s ds] over [s0, s1] (`closed_form::segment_weights`), from the exact length.
fn segment_weights(s0: vec2<f32>, s1: vec2<f32>) -> vec2<f32> {
    let length = ff_sub(s1, s0).x;
    let mid = 0.5 * (s0.x + s1.x);
    return vec2<f32>(length * (1.0 - mid), length * mid);
}

struct Edge {
    va: vec2<f32>,
    vb: vec2<f32>,
    // inside · (d.y, −d.x) (its sign is all the occlusion test needs).
    outward: vec2<f32>,
    view: u32,
    // Rank among coincident edges: the edge's lowest face index with a non-zero orientation.
    rank: u32,
}

// One edge qa → qb of an occluder with orientation o: narrows [lo, hi]; false when the interval
// becomes empty (the point outside the edge is on the wrong side of qa → qb throughout). On the
// edge's line, qa → qb removes the stretch it spans when the occluder lies on the edge's outside,
// or on its inside when the occluder ranks first among coincident edges (`yields`).
fn clip_by_occluder_edge(
    edge: Edge,
    qa: vec2<f32>,
    qb: vec2<f32>,
    o: f32,
    yields: bool,
    lo: ptr<function, vec2<f32>>,
    hi: ptr<function, vec2<f32>>,
) -> bool {
    let ux = ff_diff(qb.x, qa.x);
    let uy = ff_diff(qb.y, qa.y);
    let alpha = o * ff_cross(ux, uy, ff_diff(edge.va.x, qa.x), ff_diff(edge.va.y, qa.y));
    let beta = ff_sub(o * ff_cross(ux, uy, ff_diff(edge.vb.x, qa.x), ff_diff(edge.vb.y, qa.y)), alpha);
    if ff_is_zero(beta) {
        let inward = o * vec2<f32>(-(qb.y - qa.y), qb.x - qa.x);
        let facing = dot(inward, edge.outward);
        if alpha.x < 0.0 || (alpha.x == 0.0 && !(facing > 0.0 || (facing < 0.0 && yields))) {
            return false;
        }
    } else if beta.x > 0.0 {
        *lo = ff_max(*lo, ff_div(-alpha, beta));
    } else {
        *hi = ff_min(*hi, ff_div(-alpha, beta));
    }
    return ff_lt(*lo, *hi);
}

// The parameter interval of [c.lo, c.hi] on va + s·d whose outside is inside the triangle of bins
// entry `entry`, or that it takes over as a coincident edge (twin of `occluded_interval`); empty
// when none. `bb` is the segment's bounding box (lo, hi), already
// grown by a margin: the box test is only a filter, a triangle it lets through gets its exact
// (possibly empty) interval.
fn occluded_interval(edge: Edge, entry: u32, c: vec4<f32>, bb: vec4<f32>) -> vec4<f32> {
    let none = vec4<f32>(1.0, 0.0, 0.0, 0.0);
    let at = 2u * (entry - frame.params.bin_list_offset);
    let r0 = occluders[at];
    let r1 = occluders[at + 1u];
    let q0 = r0.xy;
    let q1 = r0.zw;
    let q2 = r1.xy;
    let qlo = min(min(q0, q1), q2);
    let qhi = max(max(q0, q1), q2);
    if qlo.x > bb.z || qlo.y > bb.w || qhi.x < bb.x || qhi.y < bb.y {
        return none;
    }
    let o = r1.z;
    if o == 0.0 {
        return none;
    }
    var lo = c.xy;
    var hi = c.zw;
    let yields = bins[entry] < edge.rank;
    // The three edges, unrolled (loops count against llvmpipe's limit).
    if !clip_by_occluder_edge(edge, q0, q1, o, yields, &lo, &hi)
        || !clip_by_occluder_edge(edge, q1, q2, o, yields, &lo, &hi)
        || !clip_by_occluder_edge(edge, q2, q0, o, yields, &lo, &hi) {
        return none;
    }
    return vec4<f32>(lo, hi);
}

// The occluder lists of a pixel: its tile's list, then its view's large-triangle list.
struct Lists {
    tile_start: u32,
    tile_count: u32,
    large_start: u32,
    large_count: u32,
}

// The bins index of entry k of the lists (its occluder record is at 2 · (index − bin_list_offset)).
fn list_entry(lists: Lists, k: u32) -> u32 {
    if k < lists.tile_count {
        return lists.tile_start + k;
    }
    return lists.large_start + k - lists.tile_count;
}

// This lane's share of a pixel's occluder scan: list entries `lane`, `lane + LANES`, …. Appends
// every non-empty interval over [c.lo, c.hi] to `wg_intervals` (slot: `wg_found` − `found`, kept
// while below SHARED) and counts in `wg_hiding` one that covers all of [c.lo, c.hi]; stops once
// any lane has found such a one (`wg_hiding` ≠ `hiding`).
fn scan_occluders(edge: Edge, lists: Lists, c: vec4<f32>, bb: vec4<f32>, found: u32, hiding: u32, lane: u32) {
    let total = lists.tile_count + lists.large_count;
    for (var k = lane; k < total && tick(); k += LANES) {
        if atomicLoad(&wg_hiding) != hiding {
            break;
        }
        let iv = occluded_interval(edge, list_entry(lists, k), c, bb);
        if iv_empty(iv) {
            continue;
        }
        if ff_le(iv.xy, c.xy) && ff_le(c.zw, iv.zw) {
            atomicAdd(&wg_hiding, 1u);
            break;
        }
        let slot = atomicAdd(&wg_found, 1u) - found;
        if slot < SHARED {
            wg_intervals[slot] = iv;
        }
    }
}

// This lane's share of sorting a pixel's `n` ≤ SHARED intervals by start: interval k goes to
// `wg_sorted[rank]`, rank = how many start before it (equal starts: by slot). Any order of equal
// starts merges to the same gaps.
fn sort_intervals(n: u32, lane: u32) {
    for (var k = lane; k < n && tick(); k += LANES) {
        let iv = wg_intervals[k];
        var rank = 0u;
        for (var j = 0u; j < n && tick(); j++) {
            let other = wg_intervals[j].xy;
            if ff_lt(other, iv.xy) || (j < k && !ff_lt(iv.xy, other)) {
                rank++;
            }
        }
        wg_sorted[rank] = iv;
    }
}

// Visible weights [∫(1 − s), ∫ s] over the parts of [c.lo, c.hi] that none of the `n` intervals
// of `wg_sorted` covers: the CPU's sorted merge, gaps in increasing order (deterministic: the same
// gaps whatever order the lanes appended the intervals in).
fn merge_sorted(c: vec4<f32>, n: u32) -> vec2<f32> {
    var weights = vec2<f32>(0.0);
    var cursor = c.xy;
    for (var k = 0u; k < n && tick(); k++) {
        let iv = wg_sorted[k];
        if ff_lt(cursor, iv.xy) {
            weights += segment_weights(cursor, iv.xy);
        }
        cursor = ff_max(cursor, iv.zw);
    }
    if ff_lt(cursor, c.zw) {
        weights += segment_weights(cursor, c.zw);
    }
    return weights;
}

// `merge_sorted` for a pixel with more than SHARED intervals, recomputed from the lists (entries
// k < n): the union is swept from c.lo; each pass over the entries either extends the covered
// prefix to the farthest end among the intervals starting inside it, or emits the gap up to the
// nearest start beyond it: the same gaps, in the same order, in O(n²) without storage.
fn visible_weights(edge: Edge, lists: Lists, c: vec4<f32>, bb: vec4<f32>, n: u32) -> vec2<f32> {
    var weights = vec2<f32>(0.0);
    var cursor = c.xy;
    // Each pass extends the cursor or moves it past a gap to an interval's start: at most 2n + 1.
    for (var sweep = 0u; sweep <= 2u * n && tick(); sweep++) {
        var reach = cursor;
        var next = c.zw;
        for (var k = 0u; k < n && tick(); k++) {
            let iv = occluded_interval(edge, list_entry(lists, k), c, bb);
            if iv_empty(iv) {
                continue;
            }
            if ff_le(iv.xy, cursor) {
                reach = ff_max(reach, iv.zw);
            } else {
                next = ff_min(next, iv.xy);
            }
        }
        if ff_lt(cursor, reach) {
            cursor = reach;
            continue;
        }
        // Nothing covers just past the cursor: a gap up to the next start (or the end).
        if ff_lt(cursor, next) {
            weights += segment_weights(cursor, next);
        }
        if ff_le(c.zw, next) {
            break;
        }
        cursor = next;
    }
    return weights;
}

// Work item `item` of a frame with `parts` parts per candidate: candidate edge `edge` (dx, dy its
// exact difference vb − va) clipped to its view and to its part's slab [slab_lo, slab_hi] of
// pixel lines along the major axis (shared/parts.wgsl): parameters `s`. `crosses`: false when the
// clipped segment is empty (or the edge is degenerate or no candidate).
struct Item {
    edge: Edge,
    dx: vec2<f32>,
    dy: vec2<f32>,
    s: vec4<f32>,
    x_major: bool,
    slab_lo: i32,
    slab_hi: i32,
    crosses: bool,
}

// Rank of edge e of `view` among coincident edges (the CPU's `coincident_rank`): the lowest index
// of its faces with a non-zero orientation (`edge_faces` lists them in increasing order).
fn coincident_rank(view: u32, e: u32) -> u32 {
    let n = frame.params.edge_count;
    let orientations = frame.params.orient_offset + view * frame.params.triangle_count;
    for (var k = edge_faces[e]; k < edge_faces[e + 1u] && tick(); k++) {
        let face = edge_faces[n + 1u + k];
        if classes[orientations + face] != 0 {
            return face;
        }
    }
    return 0xffffffffu;
}

fn item_setup(item: u32, parts: u32) -> Item {
    var it: Item;
    it.crosses = false;
    let part = item % parts;
    let i = u32(classes[candidate_list_offset() + item / parts]);
    let n_edges = frame.params.edge_count;
    let inside = classes[i];
    let view = i / n_edges;
    let e = i % n_edges;
    let base = view * frame.params.vertex_count;
    let va = screen[base + edges[2u * e]].position;
    let vb = screen[base + edges[2u * e + 1u]].position;
    it.dx = ff_diff(vb.x, va.x);
    it.dy = ff_diff(vb.y, va.y);
    if inside == 0 || (ff_is_zero(it.dx) && ff_is_zero(it.dy)) {
        return it;
    }
    it.edge = Edge(va, vb, f32(inside) * vec2<f32>(it.dy.x, -it.dx.x), view, coincident_rank(view, e));
    let r = frame.views[view].raster;
    // (Clipped in a local: naga 30's SPIR-V writer panics on a pointer to a struct member passed
    // to a function.)
    var s = vec4<f32>(0.0, 0.0, 1.0, 0.0);
    if !(clip_parameter(va.x, it.dx, 0.0, f32(r.width), &s) && clip_parameter(va.y, it.dy, 0.0, f32(r.height), &s)) {
        return it;
    }
    // This part's slab along the major axis.
    let span = part_span(va, vb, r);
    it.x_major = span.x_major;
    let part_pixels = part_length(r.tile_size);
    it.slab_lo = span.start + i32(part * part_pixels);
    it.slab_hi = it.slab_lo + i32(part_pixels) - 1;
    if it.x_major {
        it.crosses = clip_parameter(va.x, it.dx, f32(it.slab_lo), f32(it.slab_hi + 1), &s);
    } else {
        it.crosses = clip_parameter(va.y, it.dy, f32(it.slab_lo), f32(it.slab_hi + 1), &s);
    }
    it.s = s;
    return it;
}

// Entry point (ITEMS candidate × part work items per workgroup): reads `screen`, `occluders`, `edges`,
// `bins`, `classes`, `d_image`, `status`, `edge_faces`; writes one entry of `partials` per work item and the
// segment counters of `status` (see the header).
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    // Which of the workgroup's items cross a pixel; the others get zero partials here.
    if lane < ITEMS {
        let item = linear_workgroup_index(workgroup_id, num_workgroups) * ITEMS + lane;
        let parts = max(atomicLoad(&status[STATUS_PARTS]), 1u);
        if lane == 0u {
            wg_parts = parts;
        }
        var listed = NO_ITEM;
        var large = 0u;
        if item < atomicLoad(&status[STATUS_CANDIDATE_TOTAL]) * parts {
            let it = item_setup(item, parts);
            if it.crosses {
                listed = item;
                large = atomicLoad(&status[status_index(it.edge.view, STATUS_LARGE)]);
            } else {
                partials[item] = vec4<f32>(0.0);
            }
        }
        wg_items[lane] = vec2<u32>(listed, large);
    }
    let items = workgroupUniformLoad(&wg_items);
    let parts = workgroupUniformLoad(&wg_parts);
    // The counts `wg_found` / `wg_hiding` stood at after the last pixel.
    var found = 0u;
    var hiding = 0u;
    // Every loop below that holds a barrier runs the same trip count in every lane: its bounds
    // come from `workgroupUniformLoad` or from the item's uniform data. They are not cut short on
    // llvmpipe (a lane leaving early would skip barriers); they are short (≤ ITEMS items, ≤ ~2L + 1
    // pixels each) and only counted.
    for (var j = 0u; j < ITEMS; j++) {
        let item = items[j].x;
        if item == NO_ITEM {
            continue;
        }
        let large_count = items[j].y;
        let it = item_setup(item, parts);
        let edge = it.edge;
        let va = edge.va;
        let vb = edge.vb;
        let vw = frame.views[edge.view];
        let r = vw.raster;
        let scale = r.inside - r.outside;
        var wa = vec2<f32>(0.0);
        var wb = vec2<f32>(0.0);
        var segments = 0u;
        var visible = 0u;
        let large = Lists(0u, 0u, frame.params.large_offset + edge.view * frame.params.triangle_count, large_count);
        // Rows and columns are found in f32 with one extra on each side: a row or column the
        // segment does not really cross clips to nothing and is skipped.
        let d = vec2<f32>(it.dx.x, it.dy.x);
        let y_s0 = va.y + it.s.x * d.y;
        let y_s1 = va.y + it.s.z * d.y;
        var row_lo = max(i32(ceil(min(y_s0, y_s1))) - 2, 0);
        var row_hi = min(i32(floor(max(y_s0, y_s1))) + 1, i32(r.height) - 1);
        if !it.x_major {
            row_lo = max(row_lo, it.slab_lo);
            row_hi = min(row_hi, it.slab_hi);
        }
        // Margin of the occluder box filter: far above the f32 error of the boxes.
        let margin = 1e-3 * (1.0 + max(max(abs(va.x), abs(va.y)), max(abs(vb.x), abs(vb.y))) * 1e-3);

        for (var row = row_lo; row <= row_hi; row++) {
            iterations += 1u;
            var rs = it.s;
            if !clip_parameter(va.y, it.dy, f32(row), f32(row) + 1.0, &rs) {
                continue;
            }
            let x_s0 = va.x + rs.x * d.x;
            let x_s1 = va.x + rs.z * d.x;
            var col_lo = max(i32(ceil(min(x_s0, x_s1))) - 2, 0);
            var col_hi = min(i32(floor(max(x_s0, x_s1))) + 1, i32(r.width) - 1);
            if it.x_major {
                col_lo = max(col_lo, it.slab_lo);
                col_hi = min(col_hi, it.slab_hi);
            }
            for (var col = col_lo; col <= col_hi; col++) {
                iterations += 1u;
                var c = rs;
                if !clip_parameter(va.x, it.dx, f32(col), f32(col) + 1.0, &c) || ff_le(c.zw, c.xy) {
                    continue;
                }
                let on_border = (ff_is_zero(it.dy) && (va.y == f32(row) || va.y == f32(row) + 1.0))
                    || (ff_is_zero(it.dx) && (va.x == f32(col) || va.x == f32(col) + 1.0));
                let pixel = vw.pixel_offset + u32(row) * r.width + u32(col);
                let g = d_image[pixel] * scale * select(1.0, 0.5, on_border);
                if g == 0.0 {
                    continue;
                }
                segments++;
                let tile = vw.tile_offset + (u32(row) / r.tile_size) * r.tiles_x + u32(col) / r.tile_size;
                var lists = large;
                lists.tile_start = min(bins[tile], frame.params.bin_capacity);
                lists.tile_count = min(bins[tile + 1u], frame.params.bin_capacity) - lists.tile_start;
                lists.tile_start += frame.params.bin_list_offset;
                let p0 = va + c.x * d;
                let p1 = va + c.z * d;
                let bb = vec4<f32>(min(p0, p1) - margin, max(p0, p1) + margin);
                // Scan (all lanes) | barrier | sort (lanes k < n) | barrier | merge (lane 0, which
                // alone writes the item's results).
                scan_occluders(edge, lists, c, bb, found, hiding, lane);
                workgroupBarrier();
                let found_now = atomicLoad(&wg_found);
                let hiding_now = atomicLoad(&wg_hiding);
                let n = found_now - found;
                let hidden = hiding_now != hiding;
                found = found_now;
                hiding = hiding_now;
                if !hidden && n <= SHARED {
                    sort_intervals(n, lane);
                }
                workgroupBarrier();
                var k = vec2<f32>(0.0);
                if !hidden && lane == 0u {
                    if n <= SHARED {
                        k = merge_sorted(c, n);
                    } else {
                        // More intervals than workgroup memory holds: recomputed from the lists.
                        k = visible_weights(edge, lists, c, bb, lists.tile_count + lists.large_count);
                    }
                }
                if k.x != 0.0 || k.y != 0.0 {
                    visible++;
                }
                wa = ff_add(wa, ff(g * k.x));
                wb = ff_add(wb, ff(g * k.y));
            }
        }
        if lane == 0u {
            partials[item] = vec4<f32>(wa, wb);
            if segments != 0u {
                atomicAdd(&status[status_index(edge.view, STATUS_SEGMENTS)], segments);
            }
            if visible != 0u {
                atomicAdd(&status[status_index(edge.view, STATUS_VISIBLE)], visible);
            }
        }
    }
    if exhausted {
        atomicMax(&status[STATUS_MAX_ITERATIONS], 0xffffffffu);
    } else if iterations > 512u {
        atomicMax(&status[STATUS_MAX_ITERATIONS], iterations * 8u);
    }
}

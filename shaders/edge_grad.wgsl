// `edge_grad` — twin of `cpu::edge_grad::edge_grad` (src/cpu/edge_grad.rs): per candidate edge of
// every view, the analytic derivative of the loss with respect to its two endpoints, over the
// pixels it crosses, visible parts only.
//
// Reads:  `frame`, `screen`, `edges`, `bins` (the tile lists' CSR offsets), `occluders` (the
//         occluder record of every entry of the tile lists and large-triangle lists), `classes`
//         (edge sides, the candidate list), `d_image` (∂L/∂I of all views, concatenated like the
//         images), `status` (list lengths).
// Writes: `partials[k · parts + p]` = (Σ g·∫(1 − s), Σ g·∫ s) over part p of candidate k, as two
//         float-float numbers — each invocation only its own slot, no float atomics;
//         `status[status_index(view, STATUS_SEGMENTS / STATUS_VISIBLE)]` and
//         `status[STATUS_MAX_ITERATIONS]` (integer counts, atomic).
// Dispatch: 1D over candidates · parts invocations (64 per workgroup); `edge_sum` then adds the
//         parts of each edge in order and applies the outward normal.
//
// Part p of an edge covers the pixels whose coordinate along the edge's major axis lies in
// [Lp, Lp + L), L = `part_length(tile_size)` (4 to 16): at most ~2L + 1 pixels, so no invocation
// runs long (a 1000-pixel edge is 63 parts in parallel), and every pixel of the edge belongs to
// exactly one part. Small tiles (dense meshes) get short parts: their pixels hold many occluders.
//
// Per pixel: the scanline DDA of the CPU (rows the segment spans, columns within each row),
// Liang–Barsky clipping to the pixel, ½ weight for a segment lying on a pixel border, then the
// visible parts: every triangle listed in the pixel's tile (and in its view's large list) gives
// the parameter interval where the point just outside the edge (+ε·outward) is inside it, and the
// closed form is applied to the complement of their union. The CPU sorts the intervals; here the
// union is swept in increasing order without sorting (`visible_weights`), so the gaps are summed
// in the same order whatever the order of the tile lists: deterministic. Intervals are cached in
// registers (64) and recomputed from the lists when there are more.
//
// Precision: the CPU computes in f64. Here every clip parameter, occlusion bound and gap length
// is computed in float-float arithmetic (shared/ff.wgsl, ~44 bits) from differences of the f32
// inputs taken exactly, so a long edge's per-pixel weights keep their relative accuracy (plain
// f32 parameters would be off by ~1e-7 of the edge length). The discrete decisions use exact
// values: face orientations come from `classes` (the CPU's f64 signs, reproduced exactly), and
// cross products vanish exactly for shared and coincident vertices (`ff_cross`), so a face
// adjacent to the edge never occludes it. Per-pixel weights are f32 (relative error ~1e-7) and
// are summed in float-float.

//!include shared/frame.wgsl
//!include shared/ff.wgsl
//!include shared/dispatch.wgsl

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

// Reads:  `frame` (parts, partial_capacity, max_workgroups), `status` (the candidate count).
// Writes: `dispatch_args`: the workgroup grid of `main` for candidates × parts invocations (64 per
//         workgroup, tiled like `workgroup_grid` in src/gpu/mod.rs), or an empty grid and
//         `status[STATUS_PARTIALS_SHORT]` = 1 when they exceed `partial_capacity` (the host then
//         grows the buffer and runs the backward on its own).
// Dispatch: one invocation, in a fused step (forward, loss and backward in one submission),
//         between `edges` and `main`.
@compute @workgroup_size(1)
fn args() {
    let parts = max(frame.params.parts, 1u);
    let candidates = atomicLoad(&status[STATUS_CANDIDATE_TOTAL]);
    dispatch_args = array<u32, 3>(0u, 1u, 1u);
    if candidates > frame.params.partial_capacity / parts {
        atomicStore(&status[STATUS_PARTIALS_SHORT], 1u);
        return;
    }
    let groups = (candidates * parts + 63u) / 64u;
    if groups == 0u {
        return;
    }
    let limit = max(frame.params.max_workgroups, 1u);
    let y = (groups + limit - 1u) / limit;
    dispatch_args = array<u32, 3>((groups + y - 1u) / y, y, 1u);
}

// An interval [lo, hi] of float-float parameters: (lo.hi, lo.lo, hi.hi, hi.lo); empty when
// hi ≤ lo.
const CACHE: u32 = 64u;
var<private> cache: array<vec4<f32>, CACHE>;
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
}

// One edge qa → qb of an occluder with orientation o: narrows [lo, hi]; false when the interval
// becomes empty (the point outside the edge is on the wrong side of qa → qb throughout).
fn clip_by_occluder_edge(
    edge: Edge,
    qa: vec2<f32>,
    qb: vec2<f32>,
    o: f32,
    lo: ptr<function, vec2<f32>>,
    hi: ptr<function, vec2<f32>>,
) -> bool {
    let ux = ff_diff(qb.x, qa.x);
    let uy = ff_diff(qb.y, qa.y);
    let alpha = o * ff_cross(ux, uy, ff_diff(edge.va.x, qa.x), ff_diff(edge.va.y, qa.y));
    let beta = ff_sub(o * ff_cross(ux, uy, ff_diff(edge.vb.x, qa.x), ff_diff(edge.vb.y, qa.y)), alpha);
    if ff_is_zero(beta) {
        let inward = o * vec2<f32>(-(qb.y - qa.y), qb.x - qa.x);
        if alpha.x < 0.0 || (alpha.x == 0.0 && dot(inward, edge.outward) <= 0.0) {
            return false;
        }
    } else if beta.x > 0.0 {
        *lo = ff_max(*lo, ff_div(-alpha, beta));
    } else {
        *hi = ff_min(*hi, ff_div(-alpha, beta));
    }
    return ff_lt(*lo, *hi);
}

// The parameter interval of [c.lo, c.hi] on va + s·d whose outside is inside triangle t (twin of
// `occluded_interval`); empty when none. `bb` is the segment's bounding box (lo, hi), already
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
    // The three edges, unrolled (loops count against llvmpipe's limit).
    if !clip_by_occluder_edge(edge, q0, q1, o, &lo, &hi) || !clip_by_occluder_edge(edge, q1, q2, o, &lo, &hi)
        || !clip_by_occluder_edge(edge, q2, q0, o, &lo, &hi) {
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

// What `fill_cache` returns when one interval covers the whole range.
const HIDDEN: u32 = 0xffffffffu;

// Fills `cache` with the non-empty intervals, over [c.lo, c.hi], of the triangles in `lists`
// (only the first CACHE when there are more); returns how many there are, or HIDDEN as soon as one
// covers all of [c.lo, c.hi].
fn fill_cache(edge: Edge, lists: Lists, c: vec4<f32>, bb: vec4<f32>) -> u32 {
    let total = lists.tile_count + lists.large_count;
    var n = 0u;
    for (var k = 0u; k < total && tick(); k++) {
        let iv = occluded_interval(edge, list_entry(lists, k), c, bb);
        if !iv_empty(iv) {
            if ff_le(iv.xy, c.xy) && ff_le(c.zw, iv.zw) {
                return HIDDEN;
            }
            if n < CACHE {
                cache[n] = iv;
            }
            n++;
        }
    }
    return n;
}

// Interval k over [c.lo, c.hi]: from the cache, or (when the lists overflowed it) recomputed from
// list entry k.
fn interval(k: u32, cached: bool, edge: Edge, lists: Lists, c: vec4<f32>, bb: vec4<f32>) -> vec4<f32> {
    if cached {
        return cache[k];
    }
    return occluded_interval(edge, list_entry(lists, k), c, bb);
}

// Visible weights [∫(1 − s), ∫ s] over the parts of [c.lo, c.hi] that none of the `n` intervals
// (`interval`) covers. The union is swept from c.lo: each pass over the intervals either extends
// the covered prefix to the farthest end among the intervals starting inside it, or emits the gap
// up to the nearest start beyond it. Gaps come out in increasing order with the endpoints the
// CPU's sorted merge finds, whatever the order of the lists (deterministic).
fn visible_weights(edge: Edge, lists: Lists, c: vec4<f32>, bb: vec4<f32>, n: u32, cached: bool) -> vec2<f32> {
    var weights = vec2<f32>(0.0);
    var cursor = c.xy;
    // Each pass extends the cursor or moves it past a gap to an interval's start: at most 2n + 1.
    for (var sweep = 0u; sweep <= 2u * n && tick(); sweep++) {
        var reach = cursor;
        var next = c.zw;
        for (var k = 0u; k < n && tick(); k++) {
            let iv = interval(k, cached, edge, lists, c, bb);
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

// Pixels per part along an edge's major axis for a view with tiles of `tile_size` pixels
// (`stages::part_length`).
fn part_length(tile_size: u32) -> u32 {
    return clamp(4u * tile_size, 4u, 16u);
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let item = linear_invocation_index(workgroup_id, num_workgroups, local_index, 64u);
    let parts = frame.params.parts;
    if item >= atomicLoad(&status[STATUS_CANDIDATE_TOTAL]) * parts {
        return;
    }
    partials[item] = vec4<f32>(0.0);
    let part = item % parts;
    let i = u32(classes[candidate_list_offset() + item / parts]);
    let n_edges = frame.params.edge_count;
    let inside = classes[i];
    let view = i / n_edges;
    let e = i % n_edges;
    let base = view * frame.params.vertex_count;
    let va = screen[base + edges[2u * e]].position;
    let vb = screen[base + edges[2u * e + 1u]].position;
    let dx = ff_diff(vb.x, va.x);
    let dy = ff_diff(vb.y, va.y);
    if inside == 0 || (ff_is_zero(dx) && ff_is_zero(dy)) {
        return;
    }
    let side = f32(inside);
    let edge = Edge(va, vb, side * vec2<f32>(dy.x, -dx.x), view);
    let vw = frame.views[view];
    let r = vw.raster;
    var s = vec4<f32>(0.0, 0.0, 1.0, 0.0);
    if !(clip_parameter(va.x, dx, 0.0, f32(r.width), &s) && clip_parameter(va.y, dy, 0.0, f32(r.height), &s)) {
        return;
    }
    // This part's slab along the major axis.
    let x_major = abs(dx.x) >= abs(dy.x);
    let part_pixels = part_length(r.tile_size);
    let slab_lo = i32(part * part_pixels);
    let slab_hi = slab_lo + i32(part_pixels) - 1;
    if x_major {
        if !clip_parameter(va.x, dx, f32(slab_lo), f32(slab_hi + 1), &s) {
            return;
        }
    } else if !clip_parameter(va.y, dy, f32(slab_lo), f32(slab_hi + 1), &s) {
        return;
    }
    let scale = r.inside - r.outside;
    var wa = vec2<f32>(0.0);
    var wb = vec2<f32>(0.0);
    var segments = 0u;
    var visible = 0u;
    let large = Lists(0u, 0u, frame.params.large_offset + view * frame.params.triangle_count,
        atomicLoad(&status[status_index(view, STATUS_LARGE)]));
    // Rows and columns are found in f32 with one extra on each side: a row or column the
    // segment does not really cross clips to nothing and is skipped.
    let d = vec2<f32>(dx.x, dy.x);
    let y_s0 = va.y + s.x * d.y;
    let y_s1 = va.y + s.z * d.y;
    var row_lo = max(i32(ceil(min(y_s0, y_s1))) - 2, 0);
    var row_hi = min(i32(floor(max(y_s0, y_s1))) + 1, i32(r.height) - 1);
    if !x_major {
        row_lo = max(row_lo, slab_lo);
        row_hi = min(row_hi, slab_hi);
    }
    // Margin of the occluder box filter: far above the f32 error of the boxes.
    let margin = 1e-3 * (1.0 + max(max(abs(va.x), abs(va.y)), max(abs(vb.x), abs(vb.y))) * 1e-3);

    for (var row = row_lo; row <= row_hi && tick(); row++) {
        var rs = s;
        if !clip_parameter(va.y, dy, f32(row), f32(row) + 1.0, &rs) {
            continue;
        }
        let x_s0 = va.x + rs.x * d.x;
        let x_s1 = va.x + rs.z * d.x;
        var col_lo = max(i32(ceil(min(x_s0, x_s1))) - 2, 0);
        var col_hi = min(i32(floor(max(x_s0, x_s1))) + 1, i32(r.width) - 1);
        if x_major {
            col_lo = max(col_lo, slab_lo);
            col_hi = min(col_hi, slab_hi);
        }
        for (var col = col_lo; col <= col_hi && tick(); col++) {
            var c = rs;
            if !clip_parameter(va.x, dx, f32(col), f32(col) + 1.0, &c) || ff_le(c.zw, c.xy) {
                continue;
            }
            let on_border = (ff_is_zero(dy) && (va.y == f32(row) || va.y == f32(row) + 1.0))
                || (ff_is_zero(dx) && (va.x == f32(col) || va.x == f32(col) + 1.0));
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
            var k = vec2<f32>(0.0);
            let n = fill_cache(edge, lists, c, bb);
            if n <= CACHE {
                k = visible_weights(edge, lists, c, bb, n, true);
            } else if n != HIDDEN {
                // More intervals than the cache holds: recomputed from the lists as needed.
                k = visible_weights(edge, lists, c, bb, lists.tile_count + lists.large_count, false);
            }
            if k.x != 0.0 || k.y != 0.0 {
                visible++;
            }
            wa = ff_add(wa, ff(g * k.x));
            wb = ff_add(wb, ff(g * k.y));
        }
    }
    partials[item] = vec4<f32>(wa, wb);
    if segments != 0u {
        atomicAdd(&status[status_index(view, STATUS_SEGMENTS)], segments);
    }
    if visible != 0u {
        atomicAdd(&status[status_index(view, STATUS_VISIBLE)], visible);
    }
    if exhausted {
        atomicMax(&status[STATUS_MAX_ITERATIONS], 0xffffffffu);
    } else if iterations > 512u {
        atomicMax(&status[STATUS_MAX_ITERATIONS], iterations * 8u);
    }
}

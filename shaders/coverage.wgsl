// `coverage` — twin of `cpu::coverage::coverage` (src/cpu/coverage/): the F×F sample masks of
// every pixel of every view.
//
// Reads:  `frame`, `snapped` (from project.wgsl), `triangles`, `bins` (CSR offsets, per-tile triangle lists, per-view
//         large-triangle lists), `status` (the large lists' lengths).
// Writes: `masks[(pixel_offset + row · width + column) · words_per_pixel + w]` for every pixel of
//         every view (each written exactly once, by the invocation that owns the pixel).
// Dispatch: one workgroup of 256 invocations per tile (tile_size² pixels, tile_size 1 to 16 per
//         view), over the tiles of all views (`total_tiles` workgroups, tiled into a 2D grid
//         beyond 65,535).
//
// Invocation `lid` works on pixel `lid % tile_size²` of the tile as lane `lid / tile_size²` of
// `256 / tile_size²` lanes. The workgroup walks its tile's triangle list, then its view's
// large-triangle list, CHUNK triangles at a time: invocations snap one triangle each into
// workgroup memory (vertices, top-left biases, sample bounding box), then every lane tests its
// pixel's samples against its share of them (every lanes-th triangle). The lanes' bits are ORed in
// workgroup memory and one lane writes the pixel. A triangle covering the whole screen is spread
// over all tiles and pixels, and a small tile full of tiny triangles over 256 / tile_size² lanes:
// nothing is serialised. On llvmpipe each invocation also counts its loop iterations
// (`STATUS_MAX_ITERATIONS`, see `stages::LLVMPIPE_LOOP_LIMIT`).
//
// The predicate is `SnappedTriangle::covers` exactly: vertices snapped with `snap` (bit-exact,
// shared/exact.wgsl), edge functions E = dx·(py − ay) − dy·(px − ax) in exact integers, a sample
// is covered when E + bias > 0 for all three edges (top-left rule). Triangles whose snapped
// bounding box spans at most 2^14 units use 32-bit edge functions — every sample tested lies in
// that box, so |dx|, |py − ay| ≤ 2^14 and |E| < 2^30: exact — and larger ones emulated 64-bit
// integers (shared/int64.wgsl).

//!include shared/frame.wgsl
//!include shared/exact.wgsl
//!include shared/dispatch.wgsl

// Invocations per workgroup: one per pixel of the largest tile (256).
const TILE_INVOCATIONS: u32 = MAX_GPU_TILE_SIZE * MAX_GPU_TILE_SIZE;

@group(0) @binding(2) var<storage, read> triangles: array<u32>;
@group(0) @binding(3) var<storage, read> bins: array<u32>;
@group(0) @binding(4) var<storage, read_write> masks: array<u32>;
@group(0) @binding(5) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read> snapped: array<vec2<i32>>;

const SMALL_EXTENT: i32 = 16384;
const FLAG_NONEMPTY: i32 = 1;
const FLAG_SMALL: i32 = 2;
// Bits 2, 3, 4: top-left bias of edges 0, 1, 2.
const FLAG_BIAS_SHIFT: u32 = 2u;

// Triangles snapped per chunk.
const CHUNK: u32 = 128u;
// Per triangle of the current chunk: (v0.x, v0.y, v1.x, v1.y), (v2.x, v2.y, flags, 0) and the
// sample box (first column, first row, last column, last row).
var<workgroup> sh_v01: array<vec4<i32>, CHUNK>;
var<workgroup> sh_v2f: array<vec4<i32>, CHUNK>;
var<workgroup> sh_box: array<vec4<i32>, CHUNK>;
// The tile's masks: words_per_pixel words per pixel (at most 256 pixels × 8 words).
var<workgroup> sh_masks: array<atomic<u32>, 2048>;
// (first tile-list entry, tile-list length, large-list length).
var<workgroup> sh_range: vec3<u32>;
// llvmpipe accounting: the most iterations any lane needs for the current chunk, and whether to
// stop.
var<workgroup> sh_chunk_cost: atomic<u32>;
var<workgroup> sh_stop: u32;

struct Setup {
    v01: vec4<i32>,
    v2f: vec4<i32>,
    box: vec4<i32>,
}

// `SnappedTriangle::new` and `sample_box`: the triangle snapped, made counter-clockwise in the
// edge-function sense, with its biases and sample box; flags 0 when culled or of zero area.
fn setup(view: u32, t: u32) -> Setup {
    let empty = Setup(vec4<i32>(0), vec4<i32>(0), vec4<i32>(0));
    let r = frame.views[view].raster;
    let base = view * frame.params.vertex_count;
    let a = snapped[base + triangles[3u * t]];
    var b = snapped[base + triangles[3u * t + 1u]];
    var c = snapped[base + triangles[3u * t + 2u]];
    if a.x == INVALID_SNAPPED || b.x == INVALID_SNAPPED || c.x == INVALID_SNAPPED {
        return empty;
    }
    let area2 = i64_sub(i64_mul_i32(b.x - a.x, c.y - a.y), i64_mul_i32(b.y - a.y, c.x - a.x));
    if i64_is_zero(area2) {
        return empty;
    }
    if i64_is_negative(area2) {
        let t = b;
        b = c;
        c = t;
    }
    var flags = FLAG_NONEMPTY;
    let v = array<vec2<i32>, 3>(a, b, c);
    for (var k = 0u; k < 3u; k++) {
        let d = v[(k + 1u) % 3u] - v[k];
        if d.y < 0 || (d.y == 0 && d.x > 0) {
            flags |= 1 << (FLAG_BIAS_SHIFT + k);
        }
    }
    let lo = min(min(a, b), c);
    let hi = max(max(a, b), c);
    if hi.x - lo.x <= SMALL_EXTENT && hi.y - lo.y <= SMALL_EXTENT {
        flags |= FLAG_SMALL;
    }
    let h = i32(r.half_step);
    let box = vec4<i32>(
        floor_div(lo.x + h - 1, 2 * h),
        floor_div(lo.y + h - 1, 2 * h),
        floor_div(hi.x - h, 2 * h),
        floor_div(hi.y - h, 2 * h),
    );
    return Setup(vec4<i32>(a, b), vec4<i32>(c, flags, 0), box);
}

// A pixel's mask bits, as a lane collects them: bits 0–31 in `first` (F ≤ 5 needs no more, and
// a scalar stays in a register where an indexed array would go to slower memory on most GPUs),
// bits 32k to 32k + 31 in `rest[k − 1]`.
struct MaskWords {
    first: u32,
    rest: array<u32, 7>,
}

fn set_bit(m: ptr<function, MaskWords>, bit: u32) {
    if bit < 32u {
        (*m).first |= 1u << bit;
    } else {
        (*m).rest[bit / 32u - 1u] |= 1u << (bit % 32u);
    }
}

// Sets bits lo..=hi.
fn set_bits(m: ptr<function, MaskWords>, lo: u32, hi: u32) {
    var b = lo;
    while b <= hi {
        let end = min(hi, b / 32u * 32u + 31u);
        let n = end - b + 1u;
        let bits = select((1u << n) - 1u, 0xffffffffu, n == 32u) << (b % 32u);
        if b < 32u {
            (*m).first |= bits;
        } else {
            (*m).rest[b / 32u - 1u] |= bits;
        }
        b = end + 1u;
    }
}

// Word w of the mask.
fn mask_word(m: MaskWords, w: u32) -> u32 {
    if w == 0u {
        return m.first;
    }
    return m.rest[w - 1u];
}

// E + bias > 0 for 64-bit E: E ≥ 0 with the top-left bias, E > 0 without.
fn edge_passes(e: vec2<u32>, flags: i32, k: u32) -> bool {
    let bias = ((flags >> (FLAG_BIAS_SHIFT + k)) & 1) == 1;
    return !i64_is_negative(e) && (bias || !i64_is_zero(e));
}

// Iterations lane `lane` of `lanes` runs on the triangles of the current chunk, bounded over the
// tile's pixels: each triangle touching the tile as if it touched every pixel (llvmpipe runs
// invocations in SIMD batches whose loops run as long as their longest lane's).
fn chunk_cost(count: u32, lane: u32, lanes: u32, f: i32, tile_cols: vec2<i32>, tile_rows: vec2<i32>) -> u32 {
    var cost = 4u + 2u * ((count + lanes - 1u) / lanes);
    for (var j = lane; j < count; j += lanes) {
        let box = sh_box[j];
        if (sh_v2f[j].z & FLAG_NONEMPTY) != 0 && box.x <= tile_cols.y && box.z >= tile_cols.x
            && box.y <= tile_rows.y && box.w >= tile_rows.x {
            // A pixel tests at most min(F, box width) × min(F, box height) samples.
            let w = u32(min(f, box.z - box.x + 1));
            let h = u32(min(f, box.w - box.y + 1));
            cost += 3u + h * (w + 2u);
        }
    }
    return cost;
}

// Entry point (one workgroup per tile): reads `snapped`, `triangles`, the tile's lists in `bins`;
// writes the tile's sample masks to `masks` and its loop count to `status` (see the header).
@compute @workgroup_size(TILE_INVOCATIONS)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let g = linear_workgroup_index(workgroup_id, num_workgroups);
    if g >= frame.params.total_tiles {
        return;
    }
    let view = view_of_tile(g);
    let vw = frame.views[view];
    let r = vw.raster;
    let t = r.tile_size;
    let tile_pixels = t * t;
    let lanes = TILE_INVOCATIONS / tile_pixels;
    let lane = lid / tile_pixels;
    let pixel = lid % tile_pixels;
    let local_tile = g - vw.tile_offset;
    let tile_x = (local_tile % r.tiles_x) * t;
    let tile_y = (local_tile / r.tiles_x) * t;
    let px = tile_x + pixel % t;
    let py = tile_y + pixel / t;
    let in_image = px < r.width && py < r.height;
    let f = i32(r.supersample);
    let h = i32(r.half_step);
    let wpp = r.words_per_pixel;
    // This pixel's sample columns and rows.
    let pc0 = i32(px) * f;
    let pr0 = i32(py) * f;
    // The tile's sample columns and rows.
    let tile_cols = vec2<i32>(i32(tile_x) * f, i32(tile_x + t) * f - 1);
    let tile_rows = vec2<i32>(i32(tile_y) * f, i32(tile_y + t) * f - 1);

    if lid == 0u {
        let cap = frame.params.bin_capacity;
        let start = min(bins[g], cap);
        sh_range = vec3<u32>(start, min(bins[g + 1u], cap) - start, atomicLoad(&status[status_index(view, STATUS_LARGE)]));
    }
    let range = workgroupUniformLoad(&sh_range);
    let total = range.y + range.z;
    // This pixel's first word in `masks`.
    let mask_base = (vw.pixel_offset + py * r.width + px) * wpp;
    if total == 0u {
        // No triangle touches the tile (most tiles of a mesh that fills part of the view).
        if in_image && lane == 0u {
            for (var w = 0u; w < wpp; w++) {
                masks[mask_base + w] = 0u;
            }
        }
        return;
    }
    // (The first chunk's barrier orders this before the lanes' ORs.)
    for (var w = lid; w < tile_pixels * wpp; w += TILE_INVOCATIONS) {
        atomicStore(&sh_masks[w], 0u);
    }
    let large = frame.params.large_offset + view * frame.params.triangle_count;
    let counting = frame.params.loop_budget != 0u;

    var words = MaskWords(0u, array<u32, 7>(0u, 0u, 0u, 0u, 0u, 0u, 0u));
    var iterations = 0u;
    for (var chunk = 0u; chunk < total; chunk += CHUNK) {
        let k = chunk + lid;
        if lid < CHUNK {
            var s = Setup(vec4<i32>(0), vec4<i32>(0), vec4<i32>(0));
            if k < range.y {
                s = setup(view, bins[frame.params.bin_list_offset + range.x + k]);
            } else if k < total {
                s = setup(view, bins[large + k - range.y]);
            }
            sh_v01[lid] = s.v01;
            sh_v2f[lid] = s.v2f;
            sh_box[lid] = s.box;
        }
        if lid == 0u {
            atomicStore(&sh_chunk_cost, 0u);
        }
        workgroupBarrier();
        let count = min(CHUNK, total - chunk);
        if counting {
            // Past the budget (llvmpipe only, see `stages::LLVMPIPE_LOOP_LIMIT`) the tile stops
            // and reports it, so that the host fails instead of returning a truncated image. Every
            // invocation adds the chunk's largest lane cost: the same count everywhere.
            atomicMax(&sh_chunk_cost, chunk_cost(count, lane, lanes, f, tile_cols, tile_rows));
            workgroupBarrier();
            iterations += atomicLoad(&sh_chunk_cost);
            if lid == 0u {
                sh_stop = select(0u, 1u, iterations > frame.params.loop_budget);
            }
            if workgroupUniformLoad(&sh_stop) != 0u {
                break;
            }
        }
        for (var j = lane; j < count && in_image; j += lanes) {
            let v2f = sh_v2f[j];
            let flags = v2f.z;
            if (flags & FLAG_NONEMPTY) == 0 {
                continue;
            }
            let box = sh_box[j];
            let c0 = max(pc0, box.x);
            let c1 = min(pc0 + f - 1, box.z);
            let r0 = max(pr0, box.y);
            let r1 = min(pr0 + f - 1, box.w);
            if c0 > c1 || r0 > r1 {
                continue;
            }
            let v01 = sh_v01[j];
            let v = array<vec2<i32>, 3>(v01.xy, v01.zw, v2f.xy);
            let x0 = (2 * c0 + 1) * h;
            let y0 = (2 * r0 + 1) * h;
            if (flags & FLAG_SMALL) != 0 {
                // 32-bit edge functions (exact, see the header).
                var row_e = vec3<i32>(0);
                var step_x = vec3<i32>(0);
                var step_y = vec3<i32>(0);
                for (var e = 0u; e < 3u; e++) {
                    let a = v[e];
                    let d = v[(e + 1u) % 3u] - a;
                    let bias = (flags >> (FLAG_BIAS_SHIFT + e)) & 1;
                    row_e[e] = d.x * (y0 - a.y) - d.y * (x0 - a.x) + bias;
                    step_x[e] = -d.y * 2 * h;
                    step_y[e] = d.x * 2 * h;
                }
                for (var sy = r0; sy <= r1; sy++) {
                    var e = row_e;
                    let bit_row = u32((sy - pr0) * f);
                    for (var sx = c0; sx <= c1; sx++) {
                        if all(e > vec3<i32>(0)) {
                            let bit = bit_row + u32(sx - pc0);
                            set_bit(&words, bit);
                        }
                        e += step_x;
                    }
                    row_e += step_y;
                }
            } else {
                // 64-bit edge functions: E ≥ 0 (bias 1) or E > 0 (bias 0).
                var row_e = array<vec2<u32>, 3>();
                var step_x = array<vec2<u32>, 3>();
                var step_y = array<vec2<u32>, 3>();
                // E is linear: at the four corner samples of the pixel's box it takes its extremes,
                // so most pixels of a large triangle are classified whole (inside all three
                // edges, or outside one) without a per-sample loop.
                var whole = true;
                var outside = false;
                for (var e = 0u; e < 3u; e++) {
                    let a = v[e];
                    let d = v[(e + 1u) % 3u] - a;
                    row_e[e] = i64_sub(i64_mul_i32(d.x, y0 - a.y), i64_mul_i32(d.y, x0 - a.x));
                    step_x[e] = i64_mul_i32(-d.y, 2 * h);
                    step_y[e] = i64_mul_i32(d.x, 2 * h);
                    let across = i64_mul_i32(-d.y, 2 * h * (c1 - c0));
                    let down = i64_mul_i32(d.x, 2 * h * (r1 - r0));
                    let p00 = edge_passes(row_e[e], flags, e);
                    let p10 = edge_passes(i64_add(row_e[e], across), flags, e);
                    let p01 = edge_passes(i64_add(row_e[e], down), flags, e);
                    let p11 = edge_passes(i64_add(i64_add(row_e[e], across), down), flags, e);
                    whole = whole && p00 && p10 && p01 && p11;
                    outside = outside || !(p00 || p10 || p01 || p11);
                }
                if outside {
                    continue;
                }
                if whole {
                    for (var sy = r0; sy <= r1; sy++) {
                        let lo = u32((sy - pr0) * f + c0 - pc0);
                        set_bits(&words, lo, lo + u32(c1 - c0));
                    }
                    continue;
                }
                for (var sy = r0; sy <= r1; sy++) {
                    var e = row_e;
                    let bit_row = u32((sy - pr0) * f);
                    for (var sx = c0; sx <= c1; sx++) {
                        // The three edges, unrolled (loops count against llvmpipe's limit).
                        let inside = edge_passes(e[0], flags, 0u) && edge_passes(e[1], flags, 1u)
                            && edge_passes(e[2], flags, 2u);
                        e[0] = i64_add(e[0], step_x[0]);
                        e[1] = i64_add(e[1], step_x[1]);
                        e[2] = i64_add(e[2], step_x[2]);
                        if inside {
                            let bit = bit_row + u32(sx - pc0);
                            set_bit(&words, bit);
                        }
                    }
                    row_e[0] = i64_add(row_e[0], step_y[0]);
                    row_e[1] = i64_add(row_e[1], step_y[1]);
                    row_e[2] = i64_add(row_e[2], step_y[2]);
                }
            }
        }
        workgroupBarrier();
    }
    if lid == 0u && iterations > 4096u {
        atomicMax(&status[STATUS_MAX_ITERATIONS], iterations);
    }
    // OR the lanes' bits, then one lane writes the pixel.
    if in_image {
        for (var w = 0u; w < wpp; w++) {
            let word = mask_word(words, w);
            if word != 0u {
                atomicOr(&sh_masks[pixel * wpp + w], word);
            }
        }
    }
    workgroupBarrier();
    if in_image && lane == 0u {
        for (var w = 0u; w < wpp; w++) {
            masks[mask_base + w] = atomicLoad(&sh_masks[pixel * wpp + w]);
        }
    }
}

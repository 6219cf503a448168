// The tile range of a triangle, shared by `bin_count` and `bin_fill`: the GPU twin of
// `cpu::bin::triangle_tiles` (src/cpu/bin.rs) with the view's GPU tile size.
//
// A triangle is listed in every tile its snapped bounding box, grown by one fixed-point unit on
// each side, overlaps (conservative for the float geometry too, which `edge_grad` relies on).
// Triangles with a clipped vertex, and those entirely off-screen, are listed nowhere. A triangle
// spanning more than LARGE_TILES tiles is listed once, in its view's large-triangle list, which
// `coverage` and `edge_grad` consult in every tile besides the tile's own list.
//!include shared/frame.wgsl
//!include shared/exact.wgsl

// A triangle listed in more tiles than this goes to its view's large-triangle list instead of the
// tile lists (so no invocation loops over more than this many tiles).
const LARGE_TILES: i32 = 64;

// Inclusive tile range (tx0, ty0, tx1, ty1) of the triangle with snapped vertices a, b, c in view
// `view`, or tx0 = -1 when it is listed nowhere; `culled` is set when a vertex is clipped.
struct TileRange {
    range: vec4<i32>,
    culled: bool,
}

// The occluder record `edge_grad` reads for a listed triangle, stored beside its list entry
// (`occluders[2 · (entry − bin_list_offset)]` and the next): (q0, q1) and (q2, orientation, 0) in
// screen pixels, so that an occlusion test reads one contiguous record instead of following
// triangle → vertex indices. The orientation is the face's exact sign from `orient` (0 for a
// degenerate face, which occludes nothing).
fn occluder_record(s0: ScreenVertex, s1: ScreenVertex, s2: ScreenVertex, orientation: i32) -> array<vec4<f32>, 2> {
    return array<vec4<f32>, 2>(
        vec4<f32>(s0.position, s1.position),
        vec4<f32>(s2.position, f32(orientation), 0.0),
    );
}

fn is_large(r: vec4<i32>) -> bool {
    return (r.z - r.x + 1) * (r.w - r.y + 1) > LARGE_TILES;
}

fn triangle_tiles(view: u32, a: vec2<i32>, b: vec2<i32>, c: vec2<i32>) -> TileRange {
    let none = vec4<i32>(-1, -1, -1, -1);
    if a.x == INVALID_SNAPPED || b.x == INVALID_SNAPPED || c.x == INVALID_SNAPPED {
        return TileRange(none, true);
    }
    let r = frame.views[view].raster;
    let units = i32(r.units);
    let x = vec3<i32>(a.x, b.x, c.x);
    let y = vec3<i32>(a.y, b.y, c.y);
    let x_lo = floor_div(min(min(x.x, x.y), x.z) - 1, units);
    let x_hi = floor_div(max(max(x.x, x.y), x.z) + 1, units);
    let y_lo = floor_div(min(min(y.x, y.y), y.z) - 1, units);
    let y_hi = floor_div(max(max(y.x, y.y), y.z) + 1, units);
    if x_hi < 0 || x_lo >= i32(r.width) || y_hi < 0 || y_lo >= i32(r.height) {
        return TileRange(none, false);
    }
    let t = i32(r.tile_size);
    return TileRange(
        vec4<i32>(
            max(x_lo, 0) / t,
            max(y_lo, 0) / t,
            min(x_hi, i32(r.width) - 1) / t,
            min(y_hi, i32(r.height) - 1) / t,
        ),
        false,
    );
}

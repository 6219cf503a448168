// What `bin_count` and `bin_fill` read of a triangle: the bindings they share, and the triangle's
// view, screen vertices and tile range (shared/tiles.wgsl) for invocation i of the
// view_count · triangle_count grid, loaded once.
//!include shared/tiles.wgsl

@group(0) @binding(1) var<storage, read> screen: array<ScreenVertex>;
@group(0) @binding(2) var<storage, read> triangles: array<u32>;
@group(0) @binding(8) var<storage, read> snapped: array<vec2<i32>>;

struct BinnedTriangle {
    view: u32,
    // The triangle's index in the topology.
    t: u32,
    tiles: TileRange,
    s0: ScreenVertex,
    s1: ScreenVertex,
    s2: ScreenVertex,
}

fn binned_triangle(i: u32) -> BinnedTriangle {
    let n = frame.params.triangle_count;
    let view = i / n;
    let t = i % n;
    let base = view * frame.params.vertex_count;
    let tri = vec3<u32>(base + triangles[3u * t], base + triangles[3u * t + 1u], base + triangles[3u * t + 2u]);
    let tiles = triangle_tiles(view, snapped[tri.x], snapped[tri.y], snapped[tri.z]);
    return BinnedTriangle(view, t, tiles, screen[tri.x], screen[tri.y], screen[tri.z]);
}

// The sign of the CPU's f64 `cross(q1 − q0, q2 − q0)` of the face, reproduced exactly
// (`orient_f64_sign`, shared/exact.wgsl); 0 when a vertex is clipped or the face has zero area.
// `bin_count` stores it for `bin_fill`, `edges` and `edge_grad` (`classes[orient_offset + i]`).
fn face_orientation(b: BinnedTriangle) -> i32 {
    if b.s0.valid == 0u || b.s1.valid == 0u || b.s2.valid == 0u {
        return 0;
    }
    return orient_f64_sign(
        bitcast<vec2<u32>>(b.s0.position),
        bitcast<vec2<u32>>(b.s1.position),
        bitcast<vec2<u32>>(b.s2.position),
    );
}

// Its occluder record (`occluder_record`), with the face's orientation.
fn binned_record(b: BinnedTriangle, orientation: i32) -> array<vec4<f32>, 2> {
    return occluder_record(b.s0, b.s1, b.s2, orientation);
}

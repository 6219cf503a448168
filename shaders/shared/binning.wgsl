// What `bin_count` and `bin_fill` read of a triangle: the bindings they share and the triangle's
// view, tile range and occluder record (shared/tiles.wgsl), for invocation i of the
// view_count · triangle_count grid.
//!include shared/tiles.wgsl

@group(0) @binding(1) var<storage, read> screen: array<ScreenVertex>;
@group(0) @binding(2) var<storage, read> triangles: array<u32>;
@group(0) @binding(6) var<storage, read> classes: array<i32>;
@group(0) @binding(8) var<storage, read> snapped: array<vec2<i32>>;

struct BinnedTriangle {
    view: u32,
    // The triangle's index in the topology.
    t: u32,
    tiles: TileRange,
    // Its occluder record, orientation from `classes` (`orient` runs first).
    record: array<vec4<f32>, 2>,
}

fn binned_triangle(i: u32) -> BinnedTriangle {
    let n = frame.params.triangle_count;
    let view = i / n;
    let t = i % n;
    let base = view * frame.params.vertex_count;
    let tri = vec3<u32>(base + triangles[3u * t], base + triangles[3u * t + 1u], base + triangles[3u * t + 2u]);
    let tiles = triangle_tiles(view, snapped[tri.x], snapped[tri.y], snapped[tri.z]);
    let orientation = classes[frame.params.orient_offset + i];
    return BinnedTriangle(view, t, tiles, occluder_record(screen[tri.x], screen[tri.y], screen[tri.z], orientation));
}

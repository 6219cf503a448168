// `project` — twin of `cpu::project::project_and_snap` (src/cpu/project.rs): 3D vertices → screen
// vertices and their snapped twins, every view at once; `snap_vertices` snaps screen-space input.
//
// Reads:  `frame` (uniform: sizes, views), `cameras[view]` (one ViewParams per view),
//         `positions` (x, y, z per vertex, f32; in a batch every instance's vertices back to
//         back, view `k` reading its instance's from `frame.views[k].vertex_offset`).
// Writes: `screen[view · vertex_count + v]` and `snapped[view · vertex_count + v]` (as
//         `snap_vertices` does) for every view and vertex.
// Dispatch: 1D over view_count · vertex_count invocations (`dispatch_1d`, 64 per workgroup).
//
// The arithmetic repeats `ViewParams::project` operation by operation, including glam's
// (x + z) + (y + w) grouping of the 4D dot product (x86-64 SSE2), with every product kept out of
// FMA fusion (`no_fuse`) and the divisions correctly rounded in software (`div_rn`): Vulkan
// rounds f32 additions and multiplications correctly, so the screen vertices — and hence the
// images — are the CPU's to the bit. (Only a subnormal intermediate, which a device may flush,
// could differ; pixel coordinates never are.)

//!include shared/frame.wgsl
//!include shared/exact.wgsl
//!include shared/dispatch.wgsl

@group(0) @binding(1) var<storage, read> cameras: array<ViewParams>;
@group(0) @binding(2) var<storage, read> positions: array<f32>;
@group(0) @binding(3) var<storage, read_write> screen: array<ScreenVertex>;
@group(0) @binding(4) var<storage, read_write> snapped: array<vec2<i32>>;

// Reads:  `frame`, `screen` (every view).
// Writes: `snapped[view · vertex_count + v]`: the vertex on its view's fixed-point grid
//         (`RasterParams::snap_vertex`), (i32::MIN, i32::MIN) when clipped. Snapping is exact but
//         costly (`snap` in shared/exact.wgsl); binning and coverage read the result.
// Dispatch: 1D over view_count · vertex_count invocations (64 per workgroup).
@compute @workgroup_size(64)
fn snap_vertices(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let i = linear_invocation_index(workgroup_id, num_workgroups, local_index, 64u);
    let n = frame.params.vertex_count;
    if i >= n * frame.params.view_count {
        return;
    }
    snapped[i] = snapped_vertex(screen[i], frame.views[i / n].raster.units);
}

// `RasterParams::snap_vertex`: the vertex on the fixed-point grid of `units` per pixel, or
// (i32::MIN, i32::MIN) when clipped.
fn snapped_vertex(s: ScreenVertex, units: u32) -> vec2<i32> {
    if s.valid == 0u {
        return vec2<i32>(INVALID_SNAPPED, INVALID_SNAPPED);
    }
    return vec2<i32>(snap(s.position.x, units), snap(s.position.y, units));
}

fn dot_glam(r: vec4<f32>, p: vec3<f32>) -> f32 {
    let x = no_fuse(r.x * p.x);
    let y = no_fuse(r.y * p.y);
    let z = no_fuse(r.z * p.z);
    return no_fuse(x + z) + no_fuse(y + r.w);
}

// Entry point for 3D input (one invocation per view × vertex): reads `cameras`, `positions` (from
// the view's `vertex_offset`, its instance in a batch); writes `screen` and `snapped`.
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let i = linear_invocation_index(workgroup_id, num_workgroups, local_index, 64u);
    let n = frame.params.vertex_count;
    if i >= n * frame.params.view_count {
        return;
    }
    let view = cameras[i / n];
    let v = frame.views[i / n].vertex_offset + i % n;
    let p = vec3<f32>(positions[3u * v], positions[3u * v + 1u], positions[3u * v + 2u]);
    let c = vec3<f32>(dot_glam(view.row0, p), dot_glam(view.row1, p), dot_glam(view.row2, p));
    let depth = -c.z;
    let in_range = depth > view.near && depth < view.far;
    var xy = c.xy;
    if view.perspective == 1u {
        if !in_range {
            screen[i] = ScreenVertex(vec2<f32>(0.0, 0.0), 0u, 0u);
            snapped[i] = vec2<i32>(INVALID_SNAPPED, INVALID_SNAPPED);
            return;
        }
        xy = vec2<f32>(div_rn(c.x, depth), div_rn(c.y, depth));
    }
    let s = vec2<f32>(view.centre.x + no_fuse(view.scale.x * xy.x), view.centre.y - no_fuse(view.scale.y * xy.y));
    let valid = in_range && abs(s.x) < COORD_LIMIT && abs(s.y) < COORD_LIMIT;
    let vertex = ScreenVertex(select(vec2<f32>(0.0, 0.0), s, valid), select(0u, 1u, valid), 0u);
    screen[i] = vertex;
    snapped[i] = snapped_vertex(vertex, frame.views[i / n].raster.units);
}

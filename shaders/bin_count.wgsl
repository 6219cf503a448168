// `bin_count` — first half of the GPU twin of `cpu::bin::bin` (src/cpu/bin.rs): counts the
// triangles listed in every tile, and the culled triangles of every view; on the way, every
// face's orientation (`cpu::edges::face_orientations`).
//
// Reads:  `frame`, `screen` and `snapped` (all views), `triangles` (3 indices per triangle).
// Writes: `classes[orient_offset + view · triangle_count + t]` = `face_orientation` (for
//         `bin_fill`, `edges` and `edge_grad`),
//         `counts[tile]` (+1 per listed triangle, atomic; cleared by the host before),
//         `status[status_index(view, STATUS_CULLED)]` (+1 per culled triangle); a large triangle
//         (more than LARGE_TILES tiles) is appended to its view's large list instead:
//         `bins[large_offset + view · triangle_count + k]`, k from
//         `status[status_index(view, STATUS_LARGE)]` (atomic).
//         With a large triangle's entry it writes its occluder record (`occluder_record`) into
//         `occluders`.
// Dispatch: 1D over view_count · triangle_count invocations (64 per workgroup).
// Then `scan` turns the counts into CSR offsets and `bin_fill` writes the lists.

//!include shared/binning.wgsl
//!include shared/dispatch.wgsl

@group(0) @binding(3) var<storage, read_write> counts: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> bins: array<u32>;
@group(0) @binding(6) var<storage, read_write> classes: array<i32>;
@group(0) @binding(7) var<storage, read_write> occluders: array<vec4<f32>>;

// Entry point (one invocation per view × triangle): reads `screen`, `snapped`, `triangles`; counts
// tile entries in `counts`, writes face orientations to `classes`, large-triangle lists to `bins` and
// `occluders`, and counters to `status` (see the header).
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let i = linear_invocation_index(workgroup_id, num_workgroups, local_index, 64u);
    let n = frame.params.triangle_count;
    if i >= n * frame.params.view_count {
        return;
    }
    let b = binned_triangle(i);
    let orientation = face_orientation(b);
    classes[frame.params.orient_offset + i] = orientation;
    if b.tiles.culled {
        atomicAdd(&status[status_index(b.view, STATUS_CULLED)], 1u);
        return;
    }
    let r = b.tiles.range;
    if r.x < 0 {
        return;
    }
    if is_large(r) {
        let k = atomicAdd(&status[status_index(b.view, STATUS_LARGE)], 1u);
        let entry = frame.params.large_offset + b.view * n + k;
        bins[entry] = b.t;
        let record = binned_record(b, orientation);
        let at = 2u * (entry - frame.params.bin_list_offset);
        occluders[at] = record[0];
        occluders[at + 1u] = record[1];
        return;
    }
    let v = frame.views[b.view];
    for (var ty = r.y; ty <= r.w; ty++) {
        let row = v.tile_offset + u32(ty) * v.raster.tiles_x;
        for (var tx = r.x; tx <= r.z; tx++) {
            atomicAdd(&counts[row + u32(tx)], 1u);
        }
    }
}

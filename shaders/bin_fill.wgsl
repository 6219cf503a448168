// `bin_fill` — last half of the GPU twin of `cpu::bin::bin`: writes every listed triangle into
// the lists of its tiles.
//
// Reads:  `frame`, `screen`, `snapped`, `triangles`, `classes` (face orientations from
//         `bin_count`), the CSR
//         offsets `bins[0 ..= total_tiles]`.
// Writes: `bins[bin_list_offset + offsets[tile] + k]` = triangle index, for k < counts[tile],
//         and its occluder record (`occluder_record`, orientation from `classes`) at
//         `occluders[2 · (offsets[tile] + k)]` and the next;
//         `counts[tile]` is counted back down to 0 (atomic), which hands out the slots `k`.
//         Nothing is written past `bin_capacity` (the host sees the needed size in `status`,
//         grows the buffer and runs the frame again). Large triangles are skipped (`bin_count`
//         listed them per view).
// Dispatch: 1D over view_count · triangle_count invocations (64 per workgroup).
//
// The order of the triangles inside a tile's list depends on the order of the atomics; nothing
// downstream depends on it (coverage ORs sample bits, `edge_grad` merges intervals in sorted
// order), so results are deterministic.

//!include shared/binning.wgsl
//!include shared/dispatch.wgsl

@group(0) @binding(3) var<storage, read_write> counts: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> bins: array<u32>;
@group(0) @binding(6) var<storage, read> classes: array<i32>;
@group(0) @binding(7) var<storage, read_write> occluders: array<vec4<f32>>;

// Entry point (one invocation per view × triangle): reads `screen`, `snapped`, `triangles`, `classes`
// and the CSR offsets in `bins`; appends each triangle to its tiles' lists in `bins` (cursors in
// `counts`) with its record in `occluders` (see the header).
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let i = linear_invocation_index(workgroup_id, num_workgroups, local_index, 64u);
    if i >= frame.params.triangle_count * frame.params.view_count {
        return;
    }
    let b = binned_triangle(i);
    let r = b.tiles.range;
    if r.x < 0 || is_large(r) {
        return;
    }
    let record = binned_record(b, classes[frame.params.orient_offset + i]);
    let v = frame.views[b.view];
    for (var ty = r.y; ty <= r.w; ty++) {
        let row = v.tile_offset + u32(ty) * v.raster.tiles_x;
        for (var tx = r.x; tx <= r.z; tx++) {
            let tile = row + u32(tx);
            let slot = bins[tile] + atomicSub(&counts[tile], 1u) - 1u;
            if slot < frame.params.bin_capacity {
                bins[frame.params.bin_list_offset + slot] = b.t;
                occluders[2u * slot] = record[0];
                occluders[2u * slot + 1u] = record[1];
            }
        }
    }
}

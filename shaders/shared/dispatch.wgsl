// Linear indices for 1D work dispatched as a 2D grid of workgroups.
//
// WebGPU caps each dispatch dimension at 65,535 workgroups (`max_compute_workgroups_per_dimension`).
// The host (`diffsil::gpu::workgroup_grid` / `GpuContext::dispatch_1d`) therefore launches `n`
// workgroups as an `x` by `y` grid with `x * y >= n`, `x <= limit`, `y = ceil(n / limit)` and
// `x = ceil(n / y)`, in row-major order: workgroup (wx, wy) is linear workgroup `wx + wy * x`.
// Up to `y - 1` trailing workgroups, and the tail of the last real one, lie past the end of the
// work, so every shader must bounds-check the index these functions return against its element
// count. Entry points pass `@builtin(workgroup_id)`, `@builtin(num_workgroups)` and
// `@builtin(local_invocation_index)`, plus their own workgroup size.

// Row-major linear index of this workgroup in the grid.
fn linear_workgroup_index(workgroup_id: vec3<u32>, num_workgroups: vec3<u32>) -> u32 {
    return workgroup_id.x + workgroup_id.y * num_workgroups.x;
}

// Linear index of this invocation: `linear_workgroup_index * workgroup_size + local_index`.
// `workgroup_size` is the product of the entry point's `@workgroup_size` (1D: just its x).
fn linear_invocation_index(
    workgroup_id: vec3<u32>,
    num_workgroups: vec3<u32>,
    local_index: u32,
    workgroup_size: u32,
) -> u32 {
    return linear_workgroup_index(workgroup_id, num_workgroups) * workgroup_size + local_index;
}

// Smoke test for the GPU plumbing (context, include resolver, buffers, 2D-tiled dispatch,
// readback). Not a rendering stage.
//
// Reads:  `params.count` (uniform, binding 1) and `input[0 .. count)` (read-only storage, binding 0).
// Writes: `output[i] = input[i] * 2u + 1u` for every i < count (read-write storage, binding 2);
//         nothing past `count`, so extra invocations of a tiled grid write nothing.
// Dispatch: 1D over `count` invocations with `GpuContext::dispatch_1d` (may be tiled into 2D);
//           entry points `main` (64 per workgroup) and `main_wg1` (1 per workgroup).

//!include shared/dispatch.wgsl

const WORKGROUP_SIZE: u32 = 64u;

struct Params {
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<storage, read> input: array<u32>;
@group(0) @binding(1) var<uniform> params: Params;
@group(0) @binding(2) var<storage, read_write> output: array<u32>;

fn smoke(i: u32) {
    if i >= params.count {
        return;
    }
    output[i] = input[i] * 2u + 1u;
}

// The usual shape of a 1D stage: 64 invocations per workgroup.
@compute @workgroup_size(WORKGROUP_SIZE)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    smoke(linear_invocation_index(workgroup_id, num_workgroups, local_index, WORKGROUP_SIZE));
}

// One invocation per workgroup, so that 200,000 elements need 200,000 workgroups: more than
// one dispatch dimension holds, which exercises the 2D tiling on any device.
@compute @workgroup_size(1)
fn main_wg1(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
) {
    smoke(linear_workgroup_index(workgroup_id, num_workgroups));
}

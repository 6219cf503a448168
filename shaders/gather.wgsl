// `gather` — twin of `cpu::gather::gather` (src/cpu/gather.rs): per-edge gradient slots →
// per-vertex gradients, every view.
//
// Reads:  `frame`, `edges`, `vertex_edges` (vertex → edges CSR: offsets [0 ..= vertex_count],
//         then the lists), `slots` (one EdgeGrad per view and edge).
// Writes: `grads[view · vertex_count + v]` = Σ over the edges of v, in CSR order, of the slot's
//         `a` (v is the edge's first vertex) or `b`. Deterministic and atomic-free.
// Dispatch: 1D over view_count · vertex_count invocations (64 per workgroup).

//!include shared/frame.wgsl
//!include shared/dispatch.wgsl

@group(0) @binding(1) var<storage, read> edges: array<u32>;
@group(0) @binding(2) var<storage, read> vertex_edges: array<u32>;
@group(0) @binding(3) var<storage, read> slots: array<EdgeGrad>;
@group(0) @binding(4) var<storage, read_write> grads: array<vec2<f32>>;

// Entry point (one invocation per view × vertex): reads `edges`, `vertex_edges`, `slots`; writes the
// vertex's gradient to `grads`.
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
    let view = i / n;
    let v = i % n;
    let slot_base = view * frame.params.edge_count;
    var sum = vec2<f32>(0.0);
    for (var k = vertex_edges[v]; k < vertex_edges[v + 1u]; k++) {
        let e = vertex_edges[n + 1u + k];
        let slot = slots[slot_base + e];
        sum += select(slot.b, slot.a, edges[2u * e] == v);
    }
    grads[i] = sum;
}

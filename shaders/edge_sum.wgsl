// `edge_sum` — the end of `cpu::edge_grad::edge_grad` (src/cpu/edge_grad.rs): adds the parts
// `edge_grad` computed for each candidate edge, in part order, and applies the outward normal.
//
// Reads:  `frame`, `screen`, `edges`, `classes` (edge sides, candidate positions), `partials`,
//         `status` (parts per candidate).
// Writes: `slots[view · edge_count + e]` = (outward · Σ_p wa_p, outward · Σ_p wb_p) for a
//         candidate edge (outward = side · (d.y, −d.x)), zero for the others.
// Dispatch: 1D over view_count · edge_count invocations (64 per workgroup). Deterministic: a
//         fixed order of float-float sums.

//!include shared/frame.wgsl
//!include shared/ff.wgsl
//!include shared/dispatch.wgsl

@group(0) @binding(1) var<storage, read> screen: array<ScreenVertex>;
@group(0) @binding(2) var<storage, read> edges: array<u32>;
@group(0) @binding(3) var<storage, read> classes: array<i32>;
@group(0) @binding(4) var<storage, read> partials: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> slots: array<EdgeGrad>;
@group(0) @binding(6) var<storage, read> status: array<u32>;

// Entry point (one invocation per view × edge): reads `screen`, `edges`, `classes`, `partials`,
// `status`; writes the edge's gradient slot in `slots`.
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let i = linear_invocation_index(workgroup_id, num_workgroups, local_index, 64u);
    let n_edges = frame.params.edge_count;
    if i >= n_edges * frame.params.view_count {
        return;
    }
    let side = classes[i];
    if side == 0 {
        slots[i] = EdgeGrad(vec2<f32>(0.0), vec2<f32>(0.0));
        return;
    }
    let parts = max(status[STATUS_PARTS], 1u);
    let first = u32(classes[candidate_index_offset() + i]) * parts;
    var wa = vec2<f32>(0.0);
    var wb = vec2<f32>(0.0);
    for (var p = 0u; p < parts; p++) {
        let part = partials[first + p];
        wa = ff_add(wa, part.xy);
        wb = ff_add(wb, part.zw);
    }
    let view = i / n_edges;
    let e = i % n_edges;
    let base = view * frame.params.vertex_count;
    let va = screen[base + edges[2u * e]].position;
    let vb = screen[base + edges[2u * e + 1u]].position;
    let o = f32(side);
    let ox = o * ff_diff(vb.y, va.y);
    let oy = -o * ff_diff(vb.x, va.x);
    slots[i] = EdgeGrad(vec2<f32>(ff_mul(ox, wa).x, ff_mul(oy, wa).x), vec2<f32>(ff_mul(ox, wb).x, ff_mul(oy, wb).x));
}

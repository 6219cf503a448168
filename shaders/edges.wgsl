// `edges` — twin of `cpu::edges` (src/cpu/edges.rs): which mesh edges may lie on the silhouette of
// each view and on which side their inside lies, from the face orientations `bin_count` stored
// (`face_orientations`: the sign the CPU's f64 cross product of the unsnapped f32 screen positions
// has, reproduced exactly in integer arithmetic, shared/binning.wgsl), so GPU and CPU pick the
// same candidate edges, bit for bit; `edge_grad` reuses the orientations.

//!include shared/frame.wgsl
//!include shared/dispatch.wgsl
//!include shared/parts.wgsl

@group(0) @binding(1) var<storage, read> screen: array<ScreenVertex>;
@group(0) @binding(2) var<storage, read> triangles: array<u32>;
@group(0) @binding(3) var<storage, read> edges: array<u32>;
// Edge → faces CSR: offsets [0 ..= edge_count], then the face lists.
@group(0) @binding(4) var<storage, read> edge_faces: array<u32>;
// Per view: edge sides [view · edge_count + e], face orientations from `orient_offset`
// [orient_offset + view · triangle_count + t], then the candidate positions and list (see
// shared/frame.wgsl).
@group(0) @binding(5) var<storage, read_write> classes: array<i32>;
@group(0) @binding(6) var<storage, read_write> status: array<atomic<u32>>;

// Reads:  `frame`, `screen` (positions of candidates), `triangles`, `edges` (2 vertex indices per
//         edge), `edge_faces`, the face orientations in `classes`.
// Writes: `classes[view · edge_count + e]` = +1 when the faces of edge e = [a, b] all lie left of
//         a → b, −1 when all lie right, 0 otherwise (no face with a non-zero orientation, or
//         faces on both sides); a face running a → b lies on the side of its orientation, one
//         running b → a on the other. Each candidate (side ≠ 0) is appended to the candidate
//         list (`classes` from `candidate_list_offset()`, position k from
//         `status[STATUS_CANDIDATE_TOTAL]`, atomic) and k is stored at
//         `classes[candidate_index_offset() + view · edge_count + e]`;
//         `status[status_index(view, STATUS_CANDIDATES)]` (+1 per candidate);
//         `status[STATUS_PARTS]`: the most parts (shared/parts.wgsl) of any candidate (atomic max).
// Dispatch: 1D over view_count · edge_count invocations (64 per workgroup), after `bin_count`.
@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) workgroup_id: vec3<u32>,
    @builtin(num_workgroups) num_workgroups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let i = linear_invocation_index(workgroup_id, num_workgroups, local_index, 64u);
    let n = frame.params.edge_count;
    if i >= n * frame.params.view_count {
        return;
    }
    let view = i / n;
    let e = i % n;
    let a = edges[2u * e];
    let b = edges[2u * e + 1u];
    let orientations = frame.params.orient_offset + view * frame.params.triangle_count;
    var left = false;
    var right = false;
    for (var k = edge_faces[e]; k < edge_faces[e + 1u]; k++) {
        let face = edge_faces[n + 1u + k];
        let o = classes[orientations + face];
        if o == 0 {
            continue; // culled or degenerate: covers nothing on either side
        }
        let t = vec3<u32>(triangles[3u * face], triangles[3u * face + 1u], triangles[3u * face + 2u]);
        let forward = (t.x == a && t.y == b) || (t.y == a && t.z == b) || (t.z == a && t.x == b);
        let face_side = select(-o, o, forward);
        left = left || face_side > 0;
        right = right || face_side < 0;
    }
    var side = 0;
    if left && !right {
        side = 1;
    } else if right && !left {
        side = -1;
    }
    classes[i] = side;
    if side != 0 {
        atomicAdd(&status[status_index(view, STATUS_CANDIDATES)], 1u);
        let k = atomicAdd(&status[STATUS_CANDIDATE_TOTAL], 1u);
        classes[candidate_list_offset() + k] = i32(i);
        classes[candidate_index_offset() + i] = i32(k);
        let base = view * frame.params.vertex_count;
        let span = part_span(screen[base + a].position, screen[base + b].position, frame.views[view].raster);
        atomicMax(&status[STATUS_PARTS], min(span.count, frame.params.parts));
    }
}

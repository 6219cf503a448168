// The frame uniform every stage binds at @group(0) @binding(0), and helpers to find a view.
//!include shared/layout.wgsl

@group(0) @binding(0) var<uniform> frame: FrameUniform;

// The view whose pixels (in the concatenation of all views' images) contain global pixel `p`.
fn view_of_pixel(p: u32) -> u32 {
    var lo = 0u;
    var hi = frame.params.view_count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if frame.views[mid].pixel_offset <= p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// The view whose tiles contain global tile `g`.
fn view_of_tile(g: u32) -> u32 {
    var lo = 0u;
    var hi = frame.params.view_count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if frame.views[mid].tile_offset <= g {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// `x`, opaque to the optimiser: `frame.params.zero` is always 0 but the compiler cannot know, so
// a product passed through here is rounded on its own and never fused into a following addition
// (an FMA would round differently from the CPU).
fn no_fuse(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) ^ frame.params.zero);
}

// floor(a / b) for b > 0 (Rust's `div_euclid` for positive divisors).
fn floor_div(a: i32, b: i32) -> i32 {
    let q = a / b;
    return select(q, q - 1, (a % b != 0) && (a < 0));
}

// Sections of the `classes` buffer (i32 words), per view and edge or triangle:
//   [0, orient_offset)                      edge sides            (view · edge_count + e)
//   [orient_offset, candidate_index_offset) face orientations     (view · triangle_count + t)
//   [candidate_index_offset, …list_offset)  position of a candidate edge in the candidate list
//   [candidate_list_offset, …)              the candidate list: view · edge_count + e per entry
//                                           (in atomic order; nothing depends on the order)
fn candidate_index_offset() -> u32 {
    return frame.params.orient_offset + frame.params.view_count * frame.params.triangle_count;
}

fn candidate_list_offset() -> u32 {
    return candidate_index_offset() + frame.params.view_count * frame.params.edge_count;
}

// The parts of a candidate edge in `edge_grad`: slabs of `part_length` pixels along the edge's
// major axis, counted from the edge's own first pixel line, so that a short edge has one or two
// parts wherever it lies (`edges` counts them, `edge_grad` walks them).
//!include shared/layout.wgsl

// Pixels per part along an edge's major axis for a view with tiles of `tile_size` pixels
// (`mirror::part_length`): dense meshes (small tiles) get short parts, whose pixels hold many
// occluders.
fn part_length(tile_size: u32) -> u32 {
    return clamp(PART_LENGTH_PER_TILE_SIDE * tile_size, PART_LENGTH_MIN, PART_LENGTH_MAX);
}

// Where the parts of edge va → vb start and how many there are: part p covers the pixel lines
// [start + p·L, start + (p + 1)·L) of the major axis (x when |Δx| ≥ |Δy|, in f32 as here).
// `start` is one line before the lower end (clamped to the image) and the parts reach one line
// past the upper end, so every pixel the edge crosses inside the image lies in exactly one part,
// whatever the rounding of the f32 endpoints; count ≤ floor(side / L) + 1.
struct PartSpan {
    start: i32,
    count: u32,
    x_major: bool,
}

fn part_span(va: vec2<f32>, vb: vec2<f32>, r: RasterParams) -> PartSpan {
    let x_major = abs(vb.x - va.x) >= abs(vb.y - va.y);
    let m0 = select(va.y, va.x, x_major);
    let m1 = select(vb.y, vb.x, x_major);
    let side = f32(select(r.height, r.width, x_major));
    let lo = clamp(floor(min(m0, m1)) - 1.0, 0.0, side);
    let hi = clamp(max(m0, m1) + 1.0, 0.0, side);
    let length = f32(part_length(r.tile_size));
    return PartSpan(i32(lo), u32(floor((hi - lo) / length)) + 1u, x_major);
}

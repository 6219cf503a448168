// Float-float ("double-single") arithmetic: a value is hi + lo in a vec2<f32> (|lo| ≤ ulp(hi)/2),
// about 44 significant bits. `edge_grad` needs it: the CPU computes in f64, and an f32 clip
// parameter near s = 0.5 of a 500-pixel edge is off by ~3e-5 pixels, which is a relative error of
// 3e-5 in a one-pixel segment's weight.
//
// Error-free transformations (Knuth's two-sum, Dekker's two-product with Veltkamp's split) rely
// on each operation being rounded on its own: every intermediate that an optimiser could fold
// algebraically ((a + b) − a → b) passes through `no_fuse` (shared/frame.wgsl). The partial
// products of two-product are exact, so fusing them into an FMA changes nothing.
//!include shared/frame.wgsl

fn ff(x: f32) -> vec2<f32> {
    return vec2<f32>(x, 0.0);
}

// a + b exactly, as (rounded sum, error).
fn two_sum(a: f32, b: f32) -> vec2<f32> {
    let s = no_fuse(a + b);
    let bb = no_fuse(s - a);
    return vec2<f32>(s, (a - no_fuse(s - bb)) + (b - bb));
}

// a + b exactly, for |a| ≥ |b| (or a = 0).
fn quick_two_sum(a: f32, b: f32) -> vec2<f32> {
    let s = no_fuse(a + b);
    return vec2<f32>(s, b - no_fuse(s - a));
}

// Veltkamp split: a = hi + lo with hi, lo of at most 12 significant bits.
fn ff_split(a: f32) -> vec2<f32> {
    let c = no_fuse(4097.0 * a);
    let hi = no_fuse(c - no_fuse(c - a));
    return vec2<f32>(hi, a - hi);
}

// a · b exactly, as (rounded product, error). Symmetric in a and b, bit for bit.
fn two_prod(a: f32, b: f32) -> vec2<f32> {
    let p = no_fuse(a * b);
    let x = ff_split(a);
    let y = ff_split(b);
    let err = ((x.x * y.x - p) + (x.x * y.y + x.y * y.x)) + x.y * y.y;
    return vec2<f32>(p, err);
}

// a − b for f32 a, b, exactly.
fn ff_diff(a: f32, b: f32) -> vec2<f32> {
    return two_sum(a, -b);
}

fn ff_add(x: vec2<f32>, y: vec2<f32>) -> vec2<f32> {
    var s = two_sum(x.x, y.x);
    let t = two_sum(x.y, y.y);
    s = quick_two_sum(s.x, s.y + t.x);
    return quick_two_sum(s.x, s.y + t.y);
}

fn ff_sub(x: vec2<f32>, y: vec2<f32>) -> vec2<f32> {
    return ff_add(x, -y);
}

// x · y; symmetric in x and y, bit for bit (so u.x·v.y − u.y·v.x vanishes exactly for u = v).
fn ff_mul(x: vec2<f32>, y: vec2<f32>) -> vec2<f32> {
    let p = two_prod(x.x, y.x);
    return quick_two_sum(p.x, p.y + (no_fuse(x.x * y.y) + no_fuse(x.y * y.x)));
}

fn ff_mul_f(x: vec2<f32>, y: f32) -> vec2<f32> {
    let p = two_prod(x.x, y);
    return quick_two_sum(p.x, p.y + no_fuse(x.y * y));
}

// x / y (y ≠ 0), with two correction steps.
fn ff_div(x: vec2<f32>, y: vec2<f32>) -> vec2<f32> {
    let q1 = x.x / y.x;
    var r = ff_sub(x, ff_mul_f(y, q1));
    let q2 = r.x / y.x;
    r = ff_sub(r, ff_mul_f(y, q2));
    let q3 = r.x / y.x;
    return ff_add(quick_two_sum(q1, q2), ff(q3));
}

fn ff_lt(x: vec2<f32>, y: vec2<f32>) -> bool {
    return x.x < y.x || (x.x == y.x && x.y < y.y);
}

fn ff_le(x: vec2<f32>, y: vec2<f32>) -> bool {
    return !ff_lt(y, x);
}

fn ff_max(x: vec2<f32>, y: vec2<f32>) -> vec2<f32> {
    return select(x, y, ff_lt(x, y));
}

fn ff_min(x: vec2<f32>, y: vec2<f32>) -> vec2<f32> {
    return select(x, y, ff_lt(y, x));
}

fn ff_is_zero(x: vec2<f32>) -> bool {
    return x.x == 0.0;
}

// u.x·v.y − u.y·v.x, exactly 0 when the two products are equal.
fn ff_cross(ux: vec2<f32>, uy: vec2<f32>, vx: vec2<f32>, vy: vec2<f32>) -> vec2<f32> {
    let p = ff_mul(ux, vy);
    let q = ff_mul(uy, vx);
    if p.x == q.x && p.y == q.y {
        return vec2<f32>(0.0, 0.0);
    }
    return ff_sub(p, q);
}

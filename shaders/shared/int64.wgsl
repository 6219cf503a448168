// 64-bit integers emulated on `vec2<u32>` = (low word, high word), two's complement.
//
// WGSL has no 64-bit integers on most adapters (lavapipe included), and the fixed-point edge
// functions of `coverage` need products of two 31-bit values. Everything here is exact integer
// arithmetic (wrapping modulo 2^64 like Rust's `wrapping_*`), so the GPU computes the same bits as
// the CPU's `i64`. `tests/gpu/exact.rs` checks every function against Rust on random and extreme
// values.

fn i64_from_i32(x: i32) -> vec2<u32> {
    return vec2<u32>(bitcast<u32>(x), select(0u, 0xffffffffu, x < 0));
}

fn i64_add(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    let carry = select(0u, 1u, lo < a.x);
    return vec2<u32>(lo, a.y + b.y + carry);
}

fn i64_sub(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let borrow = select(0u, 1u, a.x < b.x);
    return vec2<u32>(a.x - b.x, a.y - b.y - borrow);
}

fn i64_neg(a: vec2<u32>) -> vec2<u32> {
    return i64_sub(vec2<u32>(0u, 0u), a);
}

// Full 64-bit product of two u32, via 16-bit limbs (every partial product fits in 32 bits).
fn u32_mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = p01 + p10;
    let mid_carry = select(0u, 0x10000u, mid < p01);
    let lo = p00 + (mid << 16u);
    let lo_carry = select(0u, 1u, lo < p00);
    return vec2<u32>(lo, p11 + (mid >> 16u) + mid_carry + lo_carry);
}

// |x| as u32 (exact for i32::MIN too).
fn i32_magnitude(x: i32) -> u32 {
    return select(bitcast<u32>(x), 0u - bitcast<u32>(x), x < 0);
}

// The exact product of two i32 as a 64-bit integer.
fn i64_mul_i32(a: i32, b: i32) -> vec2<u32> {
    let p = u32_mul_wide(i32_magnitude(a), i32_magnitude(b));
    return select(p, i64_neg(p), (a < 0) != (b < 0));
}

fn i64_is_negative(a: vec2<u32>) -> bool {
    return bitcast<i32>(a.y) < 0;
}

fn i64_is_zero(a: vec2<u32>) -> bool {
    return a.x == 0u && a.y == 0u;
}

// -1, 0 or 1.
fn i64_sign(a: vec2<u32>) -> i32 {
    if i64_is_negative(a) {
        return -1;
    }
    return select(1, 0, i64_is_zero(a));
}

// a < b, signed.
fn i64_lt(a: vec2<u32>, b: vec2<u32>) -> bool {
    let ah = bitcast<i32>(a.y);
    let bh = bitcast<i32>(b.y);
    return ah < bh || (ah == bh && a.x < b.x);
}

// a <= b, signed.
fn i64_le(a: vec2<u32>, b: vec2<u32>) -> bool {
    return !i64_lt(b, a);
}

// Arithmetic shift right by s (0..63): floor(a / 2^s).
fn i64_shr(a: vec2<u32>, s: u32) -> vec2<u32> {
    let hi = bitcast<i32>(a.y);
    if s == 0u {
        return a;
    }
    if s < 32u {
        return vec2<u32>((a.x >> s) | (a.y << (32u - s)), bitcast<u32>(hi >> s));
    }
    return vec2<u32>(bitcast<u32>(hi >> min(s - 32u, 31u)), bitcast<u32>(hi >> 31u));
}

// Shift left by s (0..63), wrapping.
fn i64_shl(a: vec2<u32>, s: u32) -> vec2<u32> {
    if s == 0u {
        return a;
    }
    if s < 32u {
        return vec2<u32>(a.x << s, (a.y << s) | (a.x >> (32u - s)));
    }
    return vec2<u32>(0u, a.x << (s - 32u));
}

// Number of significant bits of an unsigned 64-bit value (0 for 0).
fn u64_bit_length(a: vec2<u32>) -> u32 {
    if a.y != 0u {
        return 64u - countLeadingZeros(a.y);
    }
    return 32u - countLeadingZeros(a.x);
}

// Unsigned a < b.
fn u64_lt(a: vec2<u32>, b: vec2<u32>) -> bool {
    return a.y < b.y || (a.y == b.y && a.x < b.x);
}

// Logical shift right by s (0..63).
fn u64_shr(a: vec2<u32>, s: u32) -> vec2<u32> {
    if s == 0u {
        return a;
    }
    if s < 32u {
        return vec2<u32>((a.x >> s) | (a.y << (32u - s)), a.y >> s);
    }
    return vec2<u32>(a.y >> min(s - 32u, 31u), 0u) * select(1u, 0u, s >= 64u);
}

// The low s bits of a (s in 0..64).
fn u64_low_bits(a: vec2<u32>, s: u32) -> vec2<u32> {
    if s >= 64u {
        return a;
    }
    if s >= 32u {
        return vec2<u32>(a.x, a.y & ((1u << (s - 32u)) - 1u));
    }
    return vec2<u32>(a.x & ((1u << s) - 1u), 0u);
}

// Exact re-creations of the CPU's floating-point decisions, in integer arithmetic.
//
// GPU compilers may fuse `a * b + c` into one fused multiply-add (WGSL has no way to forbid it),
// which changes the rounding, and Vulkan does not promise IEEE behaviour for every operation. Two
// decisions must nevertheless be bit-identical to the CPU backend:
//
// - `snap(x, units)`: the CPU's `(x * units as f32 + 0.5).floor() as i32` (src/mirror.rs), i.e.
//   floor of the f32-rounded sum of the f32-rounded product and 0.5. The product is one correctly
//   rounded multiplication (nothing to fuse it with); the addition and floor are emulated on the
//   product's bits.
// - `orient_f64_sign(a, b, w)`: the sign the CPU gets from the f64 expression
//   `(b.x - a.x) * (w.y - a.y) - (b.y - a.y) * (w.x - a.x)` on f32 inputs widened to f64
//   (src/cpu/edges.rs, src/cpu/edge_grad.rs), each operation rounded to nearest-even f64 exactly
//   as the CPU does. The final subtraction only needs the sign of `P - Q`, which rounding keeps.
//
// Inputs are f32 *bit patterns* (`bitcast<u32>`), so no device can flush a subnormal input.
//!include shared/int64.wgsl

// floor(fl32(fl32(x * units) + 0.5)) for the f32 value x (CPU: `RasterParams::snap`).
fn snap(x: f32, units: u32) -> i32 {
    return floor_f32_plus_half(bitcast<u32>(x * f32(units)));
}

// floor(fl32(p + 0.5)) where p is given by its f32 bits.
fn floor_f32_plus_half(bits: u32) -> i32 {
    let biased = (bits >> 23u) & 0xffu;
    let negative = (bits >> 31u) != 0u;
    if biased == 0u {
        return 0; // zero or subnormal: |p| < 2^-126, p + 0.5 rounds to 0.5
    }
    if biased == 0xffu {
        return select(2147483647, -2147483647 - 1, negative); // inf/NaN: never valid input
    }
    let m = (bits & 0x7fffffu) | 0x800000u;
    let e = i32(biased) - 150; // p = ±m·2^e
    if e < -32 {
        return 0; // |p| < 2^-9: p + 0.5 lies in (0.498, 0.502)
    }
    if e > 6 {
        // |p| ≥ 2^30: beyond any valid snapped coordinate; saturate like Rust's `as i32`.
        return select(2147483647, -2147483647 - 1, negative);
    }
    // S = p + 0.5 as a signed fixed-point number with 32 fraction bits (|S| < 2^62, exact).
    let magnitude = i64_shl(vec2<u32>(m, 0u), u32(e + 32));
    var s = i64_add(select(magnitude, i64_neg(magnitude), negative), vec2<u32>(0x80000000u, 0u));
    let s_negative = i64_is_negative(s);
    var a = select(s, i64_neg(s), s_negative);
    // Round |S| to 24 significant bits, ties to even (f32 addition).
    let length = u64_bit_length(a);
    if length > 24u {
        let d = length - 24u;
        var q = u64_shr(a, d);
        let rem = u64_low_bits(a, d);
        let half = i64_shl(vec2<u32>(1u, 0u), d - 1u);
        if u64_lt(half, rem) || (rem.x == half.x && rem.y == half.y && (q.x & 1u) == 1u) {
            q = i64_add(q, vec2<u32>(1u, 0u));
        }
        a = i64_shl(q, d);
    }
    s = select(a, i64_neg(a), s_negative);
    // floor(S / 2^32): arithmetic shift.
    return bitcast<i32>(i64_shr(s, 32u).x);
}

// A finite f64 value in software: (-1)^negative · mant · 2^exp, with `mant` normalised to exactly
// 53 significant bits (bit 52 set) unless it is zero.
struct SoftF64 {
    negative: bool,
    exp: i32,
    mant: vec2<u32>,
}

fn soft_zero() -> SoftF64 {
    return SoftF64(false, 0, vec2<u32>(0u, 0u));
}

fn soft_is_zero(x: SoftF64) -> bool {
    return x.mant.x == 0u && x.mant.y == 0u;
}

// Rounds negative·r·2^exp (r < 2^64) to 53 bits, nearest-even. Correct as long as any sticky
// information in r is OR-ed into its last bit and r has at least two bits below the rounding
// position when it is inexact (true for every caller: they keep 61+ significant bits).
fn soft_round(negative: bool, r: vec2<u32>, exp: i32) -> SoftF64 {
    let length = u64_bit_length(r);
    if length == 0u {
        return soft_zero();
    }
    if length <= 53u {
        let up = 53u - length;
        return SoftF64(negative, exp - i32(up), i64_shl(r, up));
    }
    var d = length - 53u;
    var q = u64_shr(r, d);
    let rem = u64_low_bits(r, d);
    let half = i64_shl(vec2<u32>(1u, 0u), d - 1u);
    if u64_lt(half, rem) || (rem.x == half.x && rem.y == half.y && (q.x & 1u) == 1u) {
        q = i64_add(q, vec2<u32>(1u, 0u));
        if q.y == 0x200000u && q.x == 0u {
            q = vec2<u32>(0u, 0x100000u);
            d += 1u;
        }
    }
    return SoftF64(negative, exp + i32(d), q);
}

// (negative, integer mantissa, exponent) of an f32 bit pattern.
fn f32_decode(bits: u32) -> vec3<u32> {
    let biased = (bits >> 23u) & 0xffu;
    let frac = bits & 0x7fffffu;
    if biased == 0u {
        return vec3<u32>(bits >> 31u, frac, bitcast<u32>(-149));
    }
    return vec3<u32>(bits >> 31u, frac | 0x800000u, bitcast<u32>(i32(biased) - 150));
}

// fl64(x - y) for f32 values x, y given as bits (what the CPU gets from `x as f64 - y as f64`).
fn soft_sub_f32(x_bits: u32, y_bits: u32) -> SoftF64 {
    var x = f32_decode(x_bits);
    var y = f32_decode(y_bits ^ 0x80000000u); // x - y = x + (-y)
    if y.y == 0u {
        return soft_round(x.x != 0u, vec2<u32>(x.y, 0u), bitcast<i32>(x.z));
    }
    if x.y == 0u {
        return soft_round(y.x != 0u, vec2<u32>(y.y, 0u), bitcast<i32>(y.z));
    }
    if bitcast<i32>(x.z) < bitcast<i32>(y.z) {
        let t = x;
        x = y;
        y = t;
    }
    let k = u32(bitcast<i32>(x.z) - bitcast<i32>(y.z));
    let a = i64_shl(vec2<u32>(x.y, 0u), 39u); // < 2^63
    var b: vec2<u32>;
    if k <= 39u {
        b = i64_shl(vec2<u32>(y.y, 0u), 39u - k);
    } else if k - 39u >= 25u {
        b = vec2<u32>(1u, 0u); // y is non-zero: all sticky
    } else {
        let s = k - 39u;
        let lost = (y.y & ((1u << s) - 1u)) != 0u;
        b = vec2<u32>((y.y >> s) | select(0u, 1u, lost), 0u);
    }
    let exp = bitcast<i32>(x.z) - 39;
    if x.x == y.x {
        return soft_round(x.x != 0u, i64_add(a, b), exp);
    }
    if u64_lt(a, b) {
        return soft_round(y.x != 0u, i64_sub(b, a), exp);
    }
    return soft_round(x.x != 0u, i64_sub(a, b), exp);
}

// Sum of three u32 as a 64-bit value.
fn u64_add3(a: u32, b: u32, c: u32) -> vec2<u32> {
    return i64_add(i64_add(vec2<u32>(a, 0u), vec2<u32>(b, 0u)), vec2<u32>(c, 0u));
}

// fl64(x · y).
fn soft_mul(x: SoftF64, y: SoftF64) -> SoftF64 {
    if soft_is_zero(x) || soft_is_zero(y) {
        return soft_zero();
    }
    // 106-bit product of the two 53-bit mantissas in four words w0..w3.
    let p00 = u32_mul_wide(x.mant.x, y.mant.x);
    let p01 = u32_mul_wide(x.mant.x, y.mant.y);
    let p10 = u32_mul_wide(x.mant.y, y.mant.x);
    let p11 = u32_mul_wide(x.mant.y, y.mant.y);
    let t1 = u64_add3(p00.y, p01.x, p10.x);
    let t2 = i64_add(u64_add3(p01.y, p10.y, p11.x), vec2<u32>(t1.y, 0u));
    let w0 = p00.x;
    let w1 = t1.x;
    let w2 = t2.x;
    let w3 = p11.y + t2.y;
    // Bit length 105 or 106: keep 53 bits, i.e. drop d = 52 or 53.
    let d = select(52u, 53u, (w3 >> 9u) != 0u);
    let hi = vec2<u32>(w2, w3);
    let lo = vec2<u32>(w0, w1);
    var q = i64_add(i64_shl(hi, 64u - d), u64_shr(lo, d)); // disjoint bits: add = or
    let round_bit = (u64_shr(lo, d - 1u).x & 1u) == 1u;
    let sticky_bits = u64_low_bits(lo, d - 1u);
    let sticky = sticky_bits.x != 0u || sticky_bits.y != 0u;
    var exp = x.exp + y.exp + i32(d);
    if round_bit && (sticky || (q.x & 1u) == 1u) {
        q = i64_add(q, vec2<u32>(1u, 0u));
        if q.y == 0x200000u && q.x == 0u {
            q = vec2<u32>(0u, 0x100000u);
            exp += 1;
        }
    }
    return SoftF64(x.negative != y.negative, exp, q);
}

// Sign of x - y (-1, 0, 1).
fn soft_compare(x: SoftF64, y: SoftF64) -> i32 {
    let sx = select(select(1, -1, x.negative), 0, soft_is_zero(x));
    let sy = select(select(1, -1, y.negative), 0, soft_is_zero(y));
    if sx != sy || sx == 0 {
        return sign(sx - sy);
    }
    var magnitude = 0;
    if x.exp != y.exp {
        magnitude = select(-1, 1, x.exp > y.exp);
    } else if x.mant.y != y.mant.y {
        magnitude = select(-1, 1, x.mant.y > y.mant.y);
    } else if x.mant.x != y.mant.x {
        magnitude = select(-1, 1, x.mant.x > y.mant.x);
    }
    return sx * magnitude;
}

// The sign of the CPU's f64 `(b.x - a.x) * (w.y - a.y) - (b.y - a.y) * (w.x - a.x)` for f32
// points given as bit patterns: +1 when w lies left of a → b (screen y down: counter-clockwise in
// the edge-function sense), -1 right, 0 on the line (as far as that f64 expression can tell).
fn orient_f64_sign(a: vec2<u32>, b: vec2<u32>, w: vec2<u32>) -> i32 {
    let p = soft_mul(soft_sub_f32(b.x, a.x), soft_sub_f32(w.y, a.y));
    let q = soft_mul(soft_sub_f32(b.y, a.y), soft_sub_f32(w.x, a.x));
    return soft_compare(p, q);
}

// a / b correctly rounded (nearest, ties to even), like the CPU's f32 division. WGSL only
// promises 2.5 ulp for `/` (lavapipe happens to round correctly, most GPUs do not); this long
// division of the integer mantissas does not depend on the device. Zero, infinite and NaN
// operands, and quotients outside the normal range, fall back to `/` (never met by `project`,
// whose divisions are by a depth within [near, far]).
fn div_rn(a: f32, b: f32) -> f32 {
    let ab = bitcast<u32>(a);
    let bb = bitcast<u32>(b);
    var ea = i32((ab >> 23u) & 0xffu);
    var eb = i32((bb >> 23u) & 0xffu);
    if ea == 0xff || eb == 0xff || (bb & 0x7fffffffu) == 0u {
        return a / b;
    }
    if (ab & 0x7fffffffu) == 0u {
        return bitcast<f32>((ab ^ bb) & 0x80000000u);
    }
    var ma = ab & 0x7fffffu;
    var mb = bb & 0x7fffffu;
    // Normalise (subnormal inputs get their exponent lowered).
    if ea == 0 {
        let shift = countLeadingZeros(ma) - 8u;
        ma = ma << shift;
        ea = 1 - i32(shift);
    } else {
        ma |= 0x800000u;
    }
    if eb == 0 {
        let shift = countLeadingZeros(mb) - 8u;
        mb = mb << shift;
        eb = 1 - i32(shift);
    } else {
        mb |= 0x800000u;
    }
    var e = ea - eb + 127;
    if ma < mb {
        ma = ma << 1u;
        e -= 1;
    }
    // 25 quotient bits: floor(ma · 2^24 / mb), ma / mb in [1, 2).
    var q = 0u;
    var r = ma;
    for (var k = 0u; k < 25u; k++) {
        let bit = r >= mb;
        if bit {
            r -= mb;
        }
        q = (q << 1u) | select(0u, 1u, bit);
        r = r << 1u;
    }
    let guard = (q & 1u) == 1u;
    q = q >> 1u;
    if guard && (r != 0u || (q & 1u) == 1u) {
        q += 1u;
        if q == 0x1000000u {
            q = q >> 1u;
            e += 1;
        }
    }
    if e < 1 || e > 254 {
        return a / b;
    }
    return bitcast<f32>(((ab ^ bb) & 0x80000000u) | (u32(e) << 23u) | (q & 0x7fffffu));
}

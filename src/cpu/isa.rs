//! The instruction set of the passes over every vertex and every face, chosen when they run.
//!
//! Those passes ([`project_and_snap`](super::project::project_and_snap), the face pass of
//! [`coverage`](super::coverage::coverage), and the renderer's check that every vertex lies
//! between the near and far planes) work on blocks of eight lanes of `i32` and `f32`:
//! one 256-bit AVX2 register each. The crate is compiled for its target's baseline, which on
//! x86-64 is SSE2: there a block takes two 128-bit halves, and the 32-bit minimum, maximum and
//! conversions that SSE2 lacks take several instructions each. So on x86-64 each of these passes
//! is compiled twice, as written and with AVX2 enabled, and the second runs where the processor
//! has AVX2 ([`has_avx2`]). Both run the same operations in the same order: integer arithmetic,
//! and `f32` / `f64` operations each correctly rounded (Rust fuses no multiply and add unless
//! asked to), so their results are the same bits (tested on each pass).

/// Whether the processor runs AVX2 (std checks once and keeps the answer).
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn has_avx2() -> bool {
    std::is_x86_feature_detected!("avx2")
}

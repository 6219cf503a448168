//! The closed-form derivative of a pixel's covered area with respect to the endpoints of a
//! silhouette segment (ARCHITECTURE.md, *The method*), and the Liang–Barsky clip it is applied to.
//!
//! A segment of the silhouette boundary from `va` to `vb` with outward unit normal `n` and length
//! `L`, clipped to the pixel square to parameters `s ∈ [sa, sb]` of `va + s·(vb − va)`, changes
//! the pixel's covered area (pixel area 1) at the rate
//!
//! ```text
//! ∂area/∂va = L·n · [(sb − sa) − (sb² − sa²)/2]
//! ∂area/∂vb = L·n · [(sb² − sa²)/2]
//! ```
//!
//! (moving `va` by δ moves the point at `s` by `(1 − s)·δ`: the flux through the segment). This
//! equals the paper's Eqs. 12–16; `tests/cpu/closed_form.rs` checks one against the other.

use glam::DVec2;

/// Liang–Barsky step: narrows the parameter interval `s` so that `p0 + t·d ∈ [lo, hi]` for all
/// `t` in it. Returns `false` when the interval becomes empty (a single point is kept).
pub fn clip_parameter(p0: f64, d: f64, lo: f64, hi: f64, s: &mut (f64, f64)) -> bool {
    if d == 0.0 {
        return lo <= p0 && p0 <= hi;
    }
    let (mut t0, mut t1) = ((lo - p0) / d, (hi - p0) / d);
    if d < 0.0 {
        std::mem::swap(&mut t0, &mut t1);
    }
    s.0 = s.0.max(t0);
    s.1 = s.1.min(t1);
    s.0 <= s.1
}

/// `[∫(1 − s) ds, ∫ s ds]` over `[s0, s1]`: the weights of the two endpoints.
pub fn segment_weights(s0: f64, s1: f64) -> [f64; 2] {
    let half_sq = 0.5 * (s1 * s1 - s0 * s0);
    [(s1 - s0) - half_sq, half_sq]
}

/// Derivative of the area of pixel (`row`, `col`) covered by a region whose boundary contains
/// the segment `va → vb`, with respect to `va` and `vb`. `inside_left` says whether the region lies
/// to the left of `va → vb` (where `cross(vb − va, p − va) > 0`; screen y down). The whole segment
/// is assumed visible. Zero when the segment misses the pixel or has zero length.
pub fn pixel_area_gradient(va: DVec2, vb: DVec2, inside_left: bool, row: i64, col: i64) -> [DVec2; 2] {
    let d = vb - va;
    let mut s = (0.0, 1.0);
    if d == DVec2::ZERO
        || !clip_parameter(va.x, d.x, col as f64, col as f64 + 1.0, &mut s)
        || !clip_parameter(va.y, d.y, row as f64, row as f64 + 1.0, &mut s)
    {
        return [DVec2::ZERO; 2];
    }
    let outward = if inside_left { DVec2::new(d.y, -d.x) } else { DVec2::new(-d.y, d.x) };
    let [wa, wb] = segment_weights(s.0, s.1);
    [outward * wa, outward * wb]
}

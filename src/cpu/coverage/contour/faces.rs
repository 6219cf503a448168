//! The pass over the faces of [`coverage_and_edges`](super::coverage_and_edges): each face's
//! snapped sign, box extent and (for the `edges` stage) float orientation, in blocks of eight.

use rayon::prelude::*;

use super::super::setup::{TriangleSummary, BLOCK};
use crate::cpu::edges::orientation_sign;
use crate::mirror::{ScreenVertex, INVALID_SNAPPED};

/// Triangles per parallel task of the pass over the faces.
pub(super) const FACES_PER_TASK: usize = 16384;

/// The pass over the faces: every face's sign of its snapped area (0 for a clipped one) and, in
/// [`coverage_and_edges`](super::coverage_and_edges), its orientation; the summary of
/// [`coverage`](super::coverage).
pub(super) struct FacePass<'a> {
    /// The snapped vertices.
    pub(super) snapped: &'a [[i32; 2]],
    /// The screen vertices (read only for the orientations).
    pub(super) screen: &'a [ScreenVertex],
    /// The cap of a box extent (units).
    pub(super) limit: i32,
}

impl FacePass<'_> {
    /// Writes `signs` (with `ORIENT`, the faces' codes of [`face_code`] there, and
    /// `orientation`), one per face, in parallel tasks for a large mesh, and returns the summary.
    pub(super) fn run<const ORIENT: bool>(
        &self,
        triangles: &[[u32; 3]],
        signs: &mut [i8],
        orientation: &mut [i8],
    ) -> TriangleSummary {
        if triangles.len() <= FACES_PER_TASK {
            return self.chunk::<ORIENT>(triangles, signs, orientation);
        }
        let tasks = triangles.par_chunks(FACES_PER_TASK).zip(signs.par_chunks_mut(FACES_PER_TASK));
        let sum = |a, b| a + b;
        if ORIENT {
            tasks
                .zip(orientation.par_chunks_mut(FACES_PER_TASK))
                .map(|((tris, signs), orientation)| self.chunk::<true>(tris, signs, orientation))
                .reduce(TriangleSummary::default, sum)
        } else {
            tasks.map(|(tris, signs)| self.chunk::<false>(tris, signs, &mut [])).reduce(TriangleSummary::default, sum)
        }
    }

    /// [`FacePass::run`] of one task's faces: [`FacePass::chunk_avx2`] where the processor has
    /// AVX2, else [`FacePass::chunk_any`] (the same bits: `cpu/isa.rs`).
    fn chunk<const ORIENT: bool>(
        &self,
        triangles: &[[u32; 3]],
        signs: &mut [i8],
        orientation: &mut [i8],
    ) -> TriangleSummary {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::isa::has_avx2() {
            // SAFETY: the processor runs AVX2.
            return unsafe { self.chunk_avx2::<ORIENT>(triangles, signs, orientation) };
        }
        self.chunk_any::<ORIENT>(triangles, signs, orientation)
    }

    /// [`FacePass::chunk_any`] compiled with AVX2; only for a processor that has it.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(super) fn chunk_avx2<const ORIENT: bool>(
        &self,
        triangles: &[[u32; 3]],
        signs: &mut [i8],
        orientation: &mut [i8],
    ) -> TriangleSummary {
        self.chunk_any::<ORIENT>(triangles, signs, orientation)
    }

    /// [`FacePass::run`] of one task's faces, in blocks of eight, for any processor.
    #[inline(always)]
    pub(super) fn chunk_any<const ORIENT: bool>(
        &self,
        triangles: &[[u32; 3]],
        signs: &mut [i8],
        orientation: &mut [i8],
    ) -> TriangleSummary {
        let mut summary = TriangleSummary::default();
        let mut tris = triangles.chunks_exact(BLOCK);
        let mut sign_blocks = signs.chunks_exact_mut(BLOCK);
        let mut orientation_blocks = orientation.chunks_exact_mut(if ORIENT { BLOCK } else { 1 });
        for (t, s) in (&mut tris).zip(&mut sign_blocks) {
            let t: &[[u32; 3]; BLOCK] = t.try_into().expect("a whole block");
            let o = if ORIENT { orientation_blocks.next().expect("one orientation per face") } else { &mut [] };
            self.block::<ORIENT>(t, s, o, &mut summary);
        }
        let rest = tris.remainder();
        if let Some(&last) = rest.last() {
            // A short block: the missing lanes repeat the last face; only `rest.len()` are written.
            let mut padded = [last; BLOCK];
            padded[..rest.len()].copy_from_slice(rest);
            let o = if ORIENT { orientation_blocks.into_remainder() } else { &mut [] };
            self.block::<ORIENT>(&padded, sign_blocks.into_remainder(), o, &mut summary);
        }
        summary
    }

    /// One block: lanes computed branch-free, the first `signs.len()` signs (and with `ORIENT`
    /// orientations) written.
    #[inline(always)]
    fn block<const ORIENT: bool>(
        &self,
        tris: &[[u32; 3]; BLOCK],
        signs: &mut [i8],
        orientation: &mut [i8],
        summary: &mut TriangleSummary,
    ) {
        let (snapped, limit) = (self.snapped, self.limit);
        let (mut x, mut y) = ([[0i32; BLOCK]; 3], [[0i32; BLOCK]; 3]);
        for (l, t) in tris.iter().enumerate() {
            for k in 0..3 {
                let p = snapped[t[k] as usize];
                (x[k][l], y[k][l]) = (p[0], p[1]);
            }
        }
        let (mut extent, mut valid, mut wide, mut reach) = ([0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK]);
        let (mut ax, mut ay, mut bx, mut by) = ([0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK], [0i32; BLOCK]);
        for l in 0..BLOCK {
            let ok =
                !((x[0][l] == INVALID_SNAPPED) | (x[1][l] == INVALID_SNAPPED) | (x[2][l] == INVALID_SNAPPED)) as i32;
            let b = [
                x[0][l].min(x[1][l]).min(x[2][l]),
                y[0][l].min(y[1][l]).min(y[2][l]),
                x[0][l].max(x[1][l]).max(x[2][l]),
                y[0][l].max(y[1][l]).max(y[2][l]),
            ];
            // Masked to 0 for a clipped lane, branch-free: ok is 0 or 1, so −ok is 0 or −1.
            extent[l] = b[2].wrapping_sub(b[0]).max(b[3].wrapping_sub(b[1])).min(limit) & -ok;
            valid[l] = ok;
            // The largest |coordinate| (0 for a clipped lane).
            reach[l] = b[2].max(b[3]).max(b[0].wrapping_neg()).max(b[1].wrapping_neg()) & -ok;
            // Edge vectors (valid coordinates are within ±2^29, so these fit in i32; a clipped
            // lane's may wrap: it is masked out).
            ax[l] = x[1][l].wrapping_sub(x[0][l]);
            ay[l] = y[1][l].wrapping_sub(y[0][l]);
            bx[l] = x[2][l].wrapping_sub(x[0][l]);
            by[l] = y[2][l].wrapping_sub(y[0][l]);
            // Whether a difference reaches 2^26 (the f64 area below is exact under it).
            let reach = |d: i32| (d.wrapping_add(1 << 26) as u32 >= 1 << 27) as i32;
            wide[l] = (reach(ax[l]) | reach(ay[l]) | reach(bx[l]) | reach(by[l])) & ok;
        }
        // The sign of the snapped area: in f64, exact while every difference is below 2^26 (products
        // below 2^52, their difference below 2^53); in i64 for a block with a wider one.
        let mut sign = [0i8; BLOCK];
        // Whether every lane's float orientation is its snapped sign ([`OrientationBound`]).
        let mut decided = false;
        // Per lane: whether its float orientation is its snapped sign.
        let mut lanes = [false; BLOCK];
        if wide.iter().all(|&w| w == 0) {
            let bound = OrientationBound::new(*reach.iter().max().expect("a block has lanes"));
            for l in 0..BLOCK {
                let area2 = ax[l] as f64 * by[l] as f64 - ay[l] as f64 * bx[l] as f64;
                sign[l] = (((area2 > 0.0) as i8) - ((area2 < 0.0) as i8)) * valid[l] as i8;
                if ORIENT {
                    // Below 2^28 for a valid lane (a clipped lane's may wrap: it is not read).
                    let l1 = [ay[l], bx[l], by[l]]
                        .iter()
                        .fold(ax[l].unsigned_abs(), |s, d| s.wrapping_add(d.unsigned_abs()));
                    lanes[l] = bound.decides(area2, l1 as f64) | (valid[l] == 0);
                }
            }
            decided = ORIENT && lanes.iter().all(|&d| d);
        } else {
            for l in 0..BLOCK {
                let area2 = ax[l] as i64 * by[l] as i64 - ay[l] as i64 * bx[l] as i64;
                sign[l] = (((area2 > 0) as i8) - ((area2 < 0) as i8)) * valid[l] as i8;
            }
        }
        let n = signs.len();
        signs.copy_from_slice(&sign[..n]);
        if ORIENT && decided {
            orientation.copy_from_slice(&sign[..n]);
        } else if ORIENT {
            // The float orientation of `face_orientation` for the lanes the bound leaves open (the
            // others have their sign's); a vertex is clipped exactly when its snapped position is
            // the invalid one (the snap of a clipped screen vertex).
            let mut o = sign;
            for (l, t) in tris.iter().enumerate() {
                if !lanes[l] {
                    let [p0, p1, p2] = t.map(|v| self.screen[v as usize].position);
                    o[l] = orientation_sign(p0, p1, p2) * valid[l] as i8;
                }
            }
            orientation.copy_from_slice(&o[..n]);
            // The codes where a sign and its orientation may differ (elsewhere the code is the sign).
            let code: [i8; BLOCK] = std::array::from_fn(|l| face_code(sign[l], o[l]));
            signs.copy_from_slice(&code[..n]);
        }
        let counted: i32 = valid[..n].iter().sum();
        summary.culled += (n as i32 - counted) as u32;
        summary.counted += counted as u64;
        summary.extent_sum += extent[..n].iter().map(|&e| e as u64).sum::<u64>();
    }
}

/// When a face's float orientation ([`orientation_sign`] of its screen vertices) is the sign of
/// its snapped area, for the faces of one block.
///
/// Why. Each snapped coordinate is `⌊fl(fl(x·U) + ½)⌋` of the pixel coordinate `x` (`U` units per
/// pixel): the two f32 roundings put it within `½ + (|x·U| + 1)·2⁻²³ ≤ δ = ½ + (reach + 3)·2⁻²²`
/// of the exact `x·U`, where `reach < 2²⁹` is the largest |snapped coordinate| of the block's
/// valid vertices (`|x·U| ≤ reach·(1 + 2⁻²²) + 1`). So a face's edge vectors from its float
/// vertices, in units, differ from the snapped ones `u`, `v` by at most `2δ` per coordinate,
/// and their cross product from the snapped `area2` by at most `2δ·l1 + 8δ²`, with `l1` the
/// sum of `u`'s and `v`'s |coordinates|: beyond that the float area has the snapped sign.
/// `orientation_sign` rounds it, by a few 2⁻⁵³ of `(l1 + 4δ)²` units², which is below
/// `2⁻¹⁹·l1 + δ²` for the `l1 < 2²⁸` of the f64 path (every difference below 2²⁶). The bound
/// used, `(2δ + 2⁻¹⁷)·l1 + 9δ²`, covers both and the rounding of its own computation. A face
/// within it (one within rounding of degenerate) gets its orientation from the floats.
#[derive(Clone, Copy)]
struct OrientationBound {
    /// The coefficient of `l1` and the constant term.
    per_length: f64,
    constant: f64,
}

impl OrientationBound {
    /// The bound for a block whose valid vertices' |snapped coordinates| are at most `reach`.
    #[inline(always)]
    fn new(reach: i32) -> OrientationBound {
        let delta = 0.5 + (reach as f64 + 3.0) * (1.0 / 4_194_304.0);
        OrientationBound { per_length: 2.0 * delta + 1.0 / 131_072.0, constant: 9.0 * delta * delta }
    }

    /// Whether the float orientation of a face of snapped area `area2` (twice the area in units²,
    /// exact) and edge vectors of |coordinates| summing to `l1` is the sign of `area2`.
    #[inline(always)]
    fn decides(self, area2: f64, l1: f64) -> bool {
        area2.abs() > self.per_length * l1 + self.constant
    }
}

/// A face's snapped sign `s` and float orientation `o` in one byte, `s + 4·(o − s)`: the sign
/// itself where the two agree (most faces), and distinct for each pair `(s, o)`. The pass over the
/// edges compares two faces' codes first: most edges have equal ones and drop out at once.
/// [`code_sign`] reads the sign back.
#[inline(always)]
pub(super) fn face_code(s: i8, o: i8) -> i8 {
    s + 4 * (o - s)
}

/// The snapped sign of a [`face_code`] (the code is `s` modulo 4, and `s + 1` is 0, 1 or 2): the
/// sign itself for a byte that holds a sign (−1, 0 or 1).
#[inline(always)]
pub(super) fn code_sign(code: i8) -> i8 {
    ((code + 1) & 3) - 1
}

//! `project` — CPU twin of `shaders/project.wgsl`: 3D vertices → screen vertices for one view.

use glam::Vec3;
use rayon::prelude::*;

use crate::mirror::{RasterParams, ScreenVertex, ViewParams, COORD_LIMIT, INVALID_SNAPPED};

/// Projects every vertex with `view`; clipped vertices get `valid = 0` and position zero.
/// Reads `positions`, writes `screen` (same length).
pub fn project(view: &ViewParams, positions: &[Vec3], screen: &mut [ScreenVertex]) {
    screen.par_iter_mut().with_min_len(4096).zip(positions.par_iter()).for_each(|(out, &p)| {
        let (position, valid) = view.project(p);
        *out = ScreenVertex { position: position.to_array(), valid: valid as u32, pad: 0 };
    });
}

/// Snaps every screen vertex to the fixed-point grid of `params` (the `snap` step that ends
/// `shaders/project.wgsl`); clipped vertices become [`INVALID_SNAPPED_VERTEX`](crate::mirror::INVALID_SNAPPED_VERTEX).
/// Reads `screen`, writes `snapped` (same length).
pub fn snap(params: &RasterParams, screen: &[ScreenVertex], snapped: &mut [[i32; 2]]) {
    snapped.par_iter_mut().with_min_len(4096).zip(screen.par_iter()).for_each(|(out, v)| {
        *out = params.snap_vertex(v);
    });
}

/// [`project`] then [`snap`] in one pass (what `shaders/project.wgsl` does): fills `screen` and
/// `snapped` (resized to the number of positions) for one view.
///
/// The vertices go [`LANES`] at a time through loops the compiler vectorises: every lane does the
/// f32 operations of [`ViewParams::project`] and [`RasterParams::snap`] in the same order (the
/// camera-space rows as `(r.x·p.x + r.z·p.z) + (r.y·p.y + r.w)`, glam's SSE2 grouping, which
/// `project.wgsl` repeats), each one correctly rounded and none fused, so the results are the
/// same bits; the clipped lanes are then replaced by zero and the invalid snapped vertex.
pub fn project_and_snap(
    view: &ViewParams,
    params: &RasterParams,
    positions: &[Vec3],
    screen: &mut Vec<ScreenVertex>,
    snapped: &mut Vec<[i32; 2]>,
) {
    // Every element is written below: resizing keeps old values without clearing them.
    screen.resize(positions.len(), ScreenVertex::default());
    snapped.resize(positions.len(), [0; 2]);
    let task = |screen: &mut [ScreenVertex], snapped: &mut [[i32; 2]], positions: &[Vec3]| {
        if view.perspective == 1 {
            project_chunk::<true>(view, params, positions, screen, snapped);
        } else {
            project_chunk::<false>(view, params, positions, screen, snapped);
        }
    };
    if positions.len() <= VERTICES_PER_TASK {
        task(screen, snapped, positions);
    } else {
        screen
            .par_chunks_mut(VERTICES_PER_TASK)
            .zip(snapped.par_chunks_mut(VERTICES_PER_TASK))
            .zip(positions.par_chunks(VERTICES_PER_TASK))
            .for_each(|((screen, snapped), positions)| task(screen, snapped, positions));
    }
}

/// Vertices per block of [`project_and_snap`].
pub const LANES: usize = 8;

/// Vertices per parallel task of [`project_and_snap`] (fewer run in the calling thread).
const VERTICES_PER_TASK: usize = 16384;

/// [`project_and_snap`] for one task's vertices: [`project_chunk_avx2`] where the processor has
/// AVX2, else [`project_chunk_any`] (the same bits: `cpu/isa.rs`).
fn project_chunk<const PERSPECTIVE: bool>(
    view: &ViewParams,
    params: &RasterParams,
    positions: &[Vec3],
    screen: &mut [ScreenVertex],
    snapped: &mut [[i32; 2]],
) {
    #[cfg(target_arch = "x86_64")]
    if super::isa::has_avx2() {
        // SAFETY: the processor runs AVX2.
        return unsafe { project_chunk_avx2::<PERSPECTIVE>(view, params, positions, screen, snapped) };
    }
    project_chunk_any::<PERSPECTIVE>(view, params, positions, screen, snapped)
}

/// [`project_chunk_any`] compiled with AVX2; only for a processor that has it.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn project_chunk_avx2<const PERSPECTIVE: bool>(
    view: &ViewParams,
    params: &RasterParams,
    positions: &[Vec3],
    screen: &mut [ScreenVertex],
    snapped: &mut [[i32; 2]],
) {
    project_chunk_any::<PERSPECTIVE>(view, params, positions, screen, snapped)
}

/// [`project_and_snap`] for one task's vertices on any processor, block by block; the last,
/// short block is padded with copies of its last vertex, whose results are not written.
#[inline(always)]
fn project_chunk_any<const PERSPECTIVE: bool>(
    view: &ViewParams,
    params: &RasterParams,
    positions: &[Vec3],
    screen: &mut [ScreenVertex],
    snapped: &mut [[i32; 2]],
) {
    let mut p = positions.chunks_exact(LANES);
    let mut s = screen.chunks_exact_mut(LANES);
    let mut q = snapped.chunks_exact_mut(LANES);
    for ((p, s), q) in (&mut p).zip(&mut s).zip(&mut q) {
        project_block::<PERSPECTIVE>(view, params, p.try_into().expect("a whole block"), s, q);
    }
    let rest = p.remainder();
    if let Some(&last) = rest.last() {
        let mut padded = [last; LANES];
        padded[..rest.len()].copy_from_slice(rest);
        project_block::<PERSPECTIVE>(view, params, &padded, s.into_remainder(), q.into_remainder());
    }
}

/// One row of a view's `[R | t]` applied to `(p, 1)`, grouped as `(r.x·p.x + r.z·p.z) +
/// (r.y·p.y + r.w)`: glam's SSE2 grouping of `Vec4::dot`, which `ViewParams::camera_space` and
/// `project.wgsl` use too, written out so that a block of lanes compiles to vector operations.
#[inline(always)]
pub(crate) fn row_dot(r: [f32; 4], p: Vec3) -> f32 {
    (r[0] * p.x + r[2] * p.z) + (r[1] * p.y + r[3])
}

/// One block of [`LANES`] vertices, of which the first `screen.len()` are written.
#[inline(always)]
fn project_block<const PERSPECTIVE: bool>(
    view: &ViewParams,
    params: &RasterParams,
    p: &[Vec3; LANES],
    screen: &mut [ScreenVertex],
    snapped: &mut [[i32; 2]],
) {
    let [r0, r1, r2] = [view.row0, view.row1, view.row2];
    let units = params.units as f32;
    let (mut sx, mut sy, mut valid, mut qx, mut qy) =
        ([0f32; LANES], [0f32; LANES], [0u32; LANES], [0i32; LANES], [0i32; LANES]);
    for l in 0..LANES {
        let (cx, cy, cz) = (row_dot(r0, p[l]), row_dot(r1, p[l]), row_dot(r2, p[l]));
        let depth = -cz;
        let in_range = (depth > view.near) & (depth < view.far);
        let (u, v) = if PERSPECTIVE { (cx / depth, cy / depth) } else { (cx, cy) };
        let px = view.centre[0] + view.scale[0] * u;
        let py = view.centre[1] - view.scale[1] * v;
        let ok = in_range & (px.abs() < COORD_LIMIT) & (py.abs() < COORD_LIMIT);
        sx[l] = if ok { px } else { 0.0 };
        sy[l] = if ok { py } else { 0.0 };
        valid[l] = ok as u32;
        // RasterParams::snap on each coordinate.
        let snap = |c: f32| {
            let y = c * units + 0.5;
            let t = y as i32;
            t - (y < t as f32) as i32
        };
        qx[l] = if ok { snap(px) } else { INVALID_SNAPPED };
        qy[l] = if ok { snap(py) } else { INVALID_SNAPPED };
    }
    for (l, out) in screen.iter_mut().enumerate() {
        *out = ScreenVertex { position: [sx[l], sy[l]], valid: valid[l], pad: 0 };
    }
    for (l, out) in snapped.iter_mut().enumerate() {
        *out = [qx[l], qy[l]];
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::random::SplitMix64 as Rng;

    /// A rotated view at distance 3 (no zero entry in its rows, so that any other grouping of the
    /// sums would round differently somewhere), with near/far clipping.
    pub(crate) fn view(perspective: bool) -> ViewParams {
        ViewParams {
            row0: [0.36, 0.48, -0.8, 0.013],
            row1: [-0.8, 0.6, 0.03, -0.021],
            row2: [0.48, 0.64, 0.6, -3.0],
            centre: [31.5, 17.25],
            scale: if perspective { [40.0, 41.0] } else { [900.0, 950.0] },
            perspective: perspective as u32,
            near: 0.5,
            far: 5.0,
            width: 64,
            height: 36,
            pad0: 0,
            pad1: 0,
            pad2: 0,
        }
    }

    /// Points of every kind: ordinary, behind the camera, beyond far, exactly at near, past the
    /// coordinate limit (near the camera plane), non-finite.
    fn points(rng: &mut Rng, n: usize) -> Vec<Vec3> {
        (0..n)
            .map(|k| match k % 9 {
                0 => Vec3::new(0.0, 0.0, 2.5), // at depth 0.5 = near: clipped
                // Far out at depth about 3 (orthogonal to the third row): past the coordinate limit.
                1 => rng.range(8e4, 2e5) * if k % 2 == 0 { 1.0 } else { -1.0 } * Vec3::new(0.36, 0.48, -0.8),
                2 => Vec3::new(f32::NAN, 0.0, 0.0),
                3 => Vec3::new(0.0, f32::INFINITY, 0.0),
                4 => Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-4.0, -2.5)), // far side
                _ => Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)),
            })
            .collect()
    }

    /// The blocked, parallel pass gives the bits of `ViewParams::project` + `snap_vertex` per
    /// vertex, for every tail length of a block, a multi-task length, both projections and
    /// several supersampling factors; stale contents of the output buffers are overwritten.
    #[test]
    fn project_and_snap_matches_the_per_vertex_functions() {
        let mut rng = Rng::new(7);
        let mut lengths: Vec<usize> = (0..=2 * LANES + 1).collect();
        lengths.extend([VERTICES_PER_TASK - 1, VERTICES_PER_TASK + 3, 3 * VERTICES_PER_TASK + LANES + 5]);
        let mut kinds = [0usize; 3]; // valid, clipped, past the coordinate limit
        for perspective in [true, false] {
            let view = view(perspective);
            for f in [1, 3, 4, 16] {
                let params = RasterParams::new(64, 36, f, 1.0, 0.0).unwrap();
                for &n in &lengths {
                    let positions = points(&mut rng, n);
                    let (mut screen, mut snapped) =
                        (vec![ScreenVertex { position: [9.0; 2], valid: 7, pad: 3 }; n / 2], vec![[5; 2]; n + 9]);
                    project_and_snap(&view, &params, &positions, &mut screen, &mut snapped);
                    assert_eq!((screen.len(), snapped.len()), (n, n));
                    for (k, &p) in positions.iter().enumerate() {
                        let (position, valid) = view.project(p);
                        let expected = ScreenVertex { position: position.to_array(), valid: valid as u32, pad: 0 };
                        let got = screen[k];
                        assert_eq!(
                            (got.position.map(f32::to_bits), got.valid, got.pad),
                            (expected.position.map(f32::to_bits), expected.valid, 0),
                            "vertex {k} of {n} at {p}"
                        );
                        assert_eq!(snapped[k], params.snap_vertex(&expected), "vertex {k} of {n} at {p}");
                        if k % 9 == 1 {
                            assert!(!valid, "{p} is past the coordinate limit");
                            let depth = -(view.row2[0] * p.x + view.row2[1] * p.y + view.row2[2] * p.z + view.row2[3]);
                            assert!(depth > view.near && depth < view.far, "{p} is in the depth range");
                        }
                        kinds[if valid {
                            0
                        } else if k % 9 == 1 {
                            2
                        } else {
                            1
                        }] += 1;
                    }
                }
            }
        }
        assert!(kinds.iter().all(|&k| k > 0), "every kind of vertex occurs: {kinds:?}");
    }

    /// The pass compiled with AVX2 gives the portable pass's bits (the other tests run whichever
    /// the processor takes: AVX2 on most x86-64 machines, so this is where the portable one is
    /// checked there).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_pass_gives_the_portable_bits() {
        if !crate::cpu::isa::has_avx2() {
            eprintln!("this processor has no AVX2: nothing to compare");
            return;
        }
        let mut rng = Rng::new(11);
        for perspective in [true, false] {
            let view = view(perspective);
            for f in [1, 3, 4, 16] {
                let params = RasterParams::new(64, 36, f, 1.0, 0.0).unwrap();
                for n in (0..=2 * LANES + 1).chain([1000]) {
                    let positions = points(&mut rng, n);
                    let run = |avx2: bool| {
                        let (mut screen, mut snapped) = (vec![ScreenVertex::default(); n], vec![[0; 2]; n]);
                        match (avx2, perspective) {
                            // SAFETY: the processor runs AVX2 (checked above).
                            (true, true) => unsafe {
                                project_chunk_avx2::<true>(&view, &params, &positions, &mut screen, &mut snapped)
                            },
                            (true, false) => unsafe {
                                project_chunk_avx2::<false>(&view, &params, &positions, &mut screen, &mut snapped)
                            },
                            (false, true) => {
                                project_chunk_any::<true>(&view, &params, &positions, &mut screen, &mut snapped)
                            }
                            (false, false) => {
                                project_chunk_any::<false>(&view, &params, &positions, &mut screen, &mut snapped)
                            }
                        }
                        let screen: Vec<_> =
                            screen.iter().map(|v| (v.position.map(f32::to_bits), v.valid, v.pad)).collect();
                        (screen, snapped)
                    };
                    assert_eq!(run(true), run(false), "{n} vertices, F = {f}, perspective {perspective}");
                }
            }
        }
    }
}

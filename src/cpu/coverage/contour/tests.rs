//! The contour fill against drawing every triangle, and the face signs against i64 areas.

use super::faces::FACES_PER_TASK;
use super::*;
use crate::cpu::coverage::setup::BLOCK;
use crate::cpu::coverage::{damage, draw_triangles, folded_placement, xorshift, BackFaceSkip};
use crate::mirror::{ScreenVertex, COORD_LIMIT, INVALID_SNAPPED_VERTEX};

/// The masks and summary of [`coverage`] and of drawing the triangles.
fn both(params: &RasterParams, snapped: &[[i32; 2]], topology: &Topology) -> [(Vec<u32>, TriangleSummary); 2] {
    let n = topology.triangles().len();
    let words = params.pixel_count() * params.words_per_pixel as usize;
    let mut masks = vec![0u32; words];
    let skip = BackFaceSkip::new(topology, snapped);
    let drawn = draw_triangles(params, snapped, topology.triangles(), skip.as_ref(), &mut vec![[0; 4]; n], &mut masks);
    let a = (masks, drawn);
    // Stale contents in the outputs and the scratch must not matter.
    let mut masks = vec![u32::MAX; words];
    let mut scratch = ContourScratch::default();
    for _ in 0..2 {
        coverage(params, snapped, topology, &mut masks, &mut scratch);
    }
    let filled = coverage(params, snapped, topology, &mut masks, &mut scratch);
    [a, (masks, filled)]
}

/// [`coverage_and_edges`] gives the masks and summary of [`coverage`] and the orientations and
/// candidates of the `edges` stage's own functions (with stale contents in every output).
fn check_fused(params: &RasterParams, screen: &[ScreenVertex], snapped: &[[i32; 2]], topology: &Topology, case: &str) {
    let words = params.pixel_count() * params.words_per_pixel as usize;
    let (mut masks, mut scratch) = (vec![0u32; words], ContourScratch::default());
    let summary = coverage(params, snapped, topology, &mut masks, &mut scratch);
    let n = topology.triangles().len();
    let mut orientation = vec![0i8; n];
    crate::cpu::edges::face_orientations(screen, topology.triangles(), &mut orientation);
    let mut candidates = Vec::new();
    crate::cpu::edges::edges(&orientation, topology, &mut candidates);
    let (mut fused_masks, mut fused_orientation, mut fused_candidates) =
        (vec![u32::MAX; words], vec![7i8; n], vec![(9, 9)]);
    for _ in 0..2 {
        let edges = EdgesStage { screen, orientation: &mut fused_orientation, candidates: &mut fused_candidates };
        let fused_summary = coverage_and_edges(params, snapped, topology, &mut fused_masks, &mut scratch, edges);
        assert_eq!(fused_summary, summary, "{case}: summary");
        assert_eq!(fused_masks, masks, "{case}: masks");
        assert_eq!(fused_orientation, orientation, "{case}: orientations");
        assert_eq!(fused_candidates, candidates, "{case}: candidates");
    }
}

/// `(g, s, t)` with `a·s + b·t = g = gcd(a, b)`.
fn extended_gcd(a: i64, b: i64) -> (i64, i64, i64) {
    if b == 0 {
        (a.abs(), a.signum(), 0)
    } else {
        let (g, s, t) = extended_gcd(b, a.rem_euclid(b));
        (g, t, s - a.div_euclid(b) * t)
    }
}

/// Face signs against i64 areas and the summary against the boxes of `bin::snapped_boxes`, for
/// coordinates of every size (blocks on the f64 path, differences below 2^26, and on the i64 one above it),
/// slivers of snapped area ±1 unit² whose two products are about 2^6, 2^46 or 2^54, clipped
/// vertices, and every length of the last block.
#[test]
fn face_signs_are_exact() {
    let mut rand = xorshift(0x2545_f491_4f6c_dd1d);
    for n in (0..=2 * BLOCK + 1).chain([100, 3 * FACES_PER_TASK + 5]) {
        let mut snapped = Vec::new();
        for k in 0..n {
            // One size per block, so that whole blocks take each path.
            let scale = [1 << 10, 1 << 24, 1 << 28][k / BLOCK % 3] as f64;
            let mut coord = || ((rand() - 0.5) * scale) as i64;
            let v0 = [coord(), coord()];
            let mut v: [[i64; 2]; 3] = [v0, [coord(), coord()], [coord(), coord()]];
            if k % 2 == 1 {
                // A sliver: v2 − v0 = b + d with cross(d, b) = ±1, d = v1 − v0 (gcd 1).
                // |d| of at least half the scale, so that the top size's products exceed 2^53.
                let mut half = |sign: bool| (scale * (0.5 + 0.25 * rand())) as i64 * if sign { 1 } else { -1 };
                let mut d = [half(k % 3 == 0), half(k % 5 < 2)];
                while extended_gcd(d[0], d[1]).0 != 1 {
                    d[0] += 1;
                }
                let (_, s, t) = extended_gcd(d[0], d[1]);
                let flip = if k % 4 == 1 { 1 } else { -1 };
                let b = [-t * flip, s * flip];
                v[1] = [v0[0] + d[0], v0[1] + d[1]];
                v[2] = [v0[0] + b[0] + d[0], v0[1] + b[1] + d[1]];
            }
            let mut v = v.map(|p| [p[0] as i32, p[1] as i32]);
            if k % 9 == 4 && k / BLOCK % 4 == 3 {
                v[k % 3] = INVALID_SNAPPED_VERTEX;
            }
            snapped.extend(v);
        }
        let triangles: Vec<[u32; 3]> = (0..n as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
        let mut signs = vec![9i8; n];
        let limit = 1 << 20;
        let faces = FacePass { snapped: &snapped, screen: &[], limit: limit as i32 };
        let summary = faces.run::<false>(&triangles, &mut signs, &mut []);
        let mut expected = TriangleSummary::default();
        for b in crate::cpu::bin::snapped_boxes(&snapped, &triangles) {
            if b == crate::cpu::bin::CULLED_BOX {
                expected.culled += 1;
            } else {
                expected.counted += 1;
                expected.extent_sum += ((b[2] - b[0]) as i64).max((b[3] - b[1]) as i64).min(limit) as u64;
            }
        }
        assert_eq!(summary, expected, "n = {n}");
        for (k, t) in triangles.iter().enumerate() {
            let v = t.map(|i| snapped[i as usize]);
            let expected = if v.contains(&INVALID_SNAPPED_VERTEX) {
                0
            } else {
                let w = v.map(|p| [p[0] as i64, p[1] as i64]);
                let area2 = crate::cpu::coverage::triangle::area2(&w);
                if k % 2 == 1 {
                    assert_eq!(area2.abs(), 1, "the sliver's area");
                }
                area2.signum() as i8
            };
            assert_eq!(signs[k], expected, "n = {n}, face {k}: {v:?}");
        }
    }
}

/// Closed meshes, meshes with holes, flipped faces and open patches, under random (folded)
/// 2D placements with many exact ties on sample positions: the same masks and summary.
#[test]
fn contour_fill_matches_drawing_on_meshes() {
    let mut rand = xorshift(0x5851_f42d_4c95_7f2d);
    let sphere = crate::scene::shapes::icosphere(3);
    let closed = sphere.triangles().to_vec();
    let mut covered_some = false;
    for case in 0..160 {
        let mut triangles = closed.clone();
        if case % 5 == 4 {
            // Non-manifold: some faces repeated, some repeated flipped, some degenerate.
            let extra: Vec<[u32; 3]> = triangles.iter().filter(|_| rand() < 0.05).copied().collect();
            triangles.extend(extra.iter().map(|t| [t[0], t[2], t[1]]));
            triangles.extend(extra.iter().take(20));
            triangles.extend(extra.iter().take(10).map(|t| [t[0], t[0], t[1]]));
        } else {
            damage(&mut triangles, case % 5, &mut rand);
        }
        let f = [1, 2, 3, 4, 5, 6][case % 6];
        let (w, h) = (23 + case as u32 % 9, 17 + case as u32 % 5);
        let params = RasterParams::new(w, h, f, 1.0, 0.0).unwrap();
        let topology = Topology::new(sphere.positions().len(), triangles).unwrap();
        let scale = [0.45, 0.45, 0.2, 1.5][case % 4];
        let mut screen = folded_placement(sphere.positions(), (w, h, f), scale, case % 3 == 0, &mut rand);
        if case % 7 == 3 {
            // Clipped vertices: their faces are culled.
            for v in screen.iter_mut().filter(|_| rand() < 0.02) {
                v.valid = 0;
            }
        }
        let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
        check_fused(&params, &screen, &snapped, &topology, &format!("case {case}"));
        let [drawn, filled] = both(&params, &snapped, &topology);
        assert_eq!(drawn.1, filled.1, "case {case}: summary");
        assert_eq!(drawn.0, filled.0, "case {case}: masks");
        covered_some |= drawn.0.iter().any(|&m| m != 0) && drawn.0.contains(&0);
    }
    assert!(covered_some);
}

/// Triangle soups (no shared edges), large triangles with vertices far off the image and at
/// the coordinate limit, and slivers: the same masks.
#[test]
fn contour_fill_matches_drawing_on_soups() {
    let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
    let mut rand = move || next() as f32;
    for case in 0..40 {
        let (f, w, h) = [(4, 13, 9), (3, 10, 12), (1, 17, 5), (7, 8, 8)][case % 4];
        let params = RasterParams::new(w, h, f, 1.0, 0.0).unwrap();
        let n = [1, 7, 60, 400][case % 4];
        let mut screen = Vec::new();
        for k in 0..n {
            let c = [rand() * (w as f32 + 6.0) - 3.0, rand() * (h as f32 + 6.0) - 3.0];
            let size = [0.3, 1.5, 6.0, 40.0][k % 4];
            for j in 0..3 {
                let mut p = [c[0] + (rand() - 0.5) * size, c[1] + (rand() - 0.5) * size];
                if k % 11 == 5 && j == 1 {
                    p[0] = (COORD_LIMIT - 1.0) * if k % 2 == 0 { 1.0 } else { -1.0 };
                }
                if k % 17 == 3 && j == 2 {
                    p[1] = -(COORD_LIMIT - 1.0);
                }
                if k % 5 == 4 {
                    p = p.map(|c| (c * 2.0 * f as f32).round() / (2.0 * f as f32));
                }
                screen.push(ScreenVertex { position: p, valid: (k % 13 != 7 || j != 2) as u32, pad: 0 });
            }
        }
        let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
        let triangles: Vec<[u32; 3]> = (0..n as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
        let topology = Topology::new(snapped.len(), triangles).unwrap();
        check_fused(&params, &screen, &snapped, &topology, &format!("soup {case}"));
        let [drawn, filled] = both(&params, &snapped, &topology);
        assert_eq!(drawn, filled, "case {case}");
    }
}

/// Large meshes take the parallel paths (faces in tasks, rows in halves): the same masks as
/// drawing, at several resolutions.
#[test]
fn contour_fill_matches_drawing_in_parallel() {
    let sphere = crate::scene::shapes::icosphere(6);
    assert!(sphere.triangles().len() > 2 * FACES_PER_TASK);
    for (res, f) in [(16, 4), (200, 4), (300, 3)] {
        let params = RasterParams::new(res, res, f, 1.0, 0.0).unwrap();
        let screen: Vec<ScreenVertex> = sphere
            .positions()
            .iter()
            .map(|p| {
                let s = res as f32 * 0.4;
                let q = [res as f32 / 2.0 + s * (p.x + 0.3 * p.z), res as f32 / 2.0 - s * (p.y + 0.2 * p.x * p.x)];
                ScreenVertex { position: q, valid: 1, pad: 0 }
            })
            .collect();
        let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
        assert!(sphere.topology().edges().len() > PARALLEL_EDGES);
        check_fused(&params, &screen, &snapped, sphere.topology(), &format!("{res}² F={f}"));
        let [drawn, filled] = both(&params, &snapped, sphere.topology());
        assert_eq!(drawn, filled, "{res}² F={f}");
        // The rows halved down to single rows: the same masks.
        let mut scratch = ContourScratch::default();
        let mut masks = vec![u32::MAX; drawn.0.len()];
        coverage(&params, &snapped, sphere.topology(), &mut masks, &mut scratch);
        masks.fill(u32::MAX);
        sweep(&params, &mut scratch.by_row, &scratch.row_offsets, &mut masks, 1);
        assert_eq!(drawn.0, masks, "{res}² F={f}, rows in parallel halves");
    }
}

/// An orientation slice that is not one per face is refused, not left partly unwritten (a mesh
/// large enough for the faces' parallel tasks, whose zip would stop at the shorter slice).
#[test]
#[should_panic(expected = "one orientation per face")]
fn coverage_and_edges_refuses_a_short_orientation_slice() {
    let sphere = crate::scene::shapes::icosphere(5);
    assert!(sphere.triangles().len() > FACES_PER_TASK);
    let params = RasterParams::new(8, 8, 4, 1.0, 0.0).unwrap();
    let screen: Vec<ScreenVertex> = sphere
        .positions()
        .iter()
        .map(|p| ScreenVertex { position: [4.0 + 3.0 * p.x, 4.0 + 3.0 * p.y], valid: 1, pad: 0 })
        .collect();
    let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
    let mut masks = vec![0u32; params.pixel_count() * params.words_per_pixel as usize];
    let mut orientation = vec![0i8; FACES_PER_TASK];
    let edges = EdgesStage { screen: &screen, orientation: &mut orientation, candidates: &mut Vec::new() };
    coverage_and_edges(&params, &snapped, sphere.topology(), &mut masks, &mut ContourScratch::default(), edges);
}

/// Faces within rounding of degenerate, one per block of eight among large ones, at coordinates
/// from the image to near the coordinate limit and for a supersampling with a power-of-two grid
/// and one without: the fused pass's orientations are the floats' ([`OrientationBound`] lets
/// the snapped sign stand only where the floats cannot disagree), and the cases include
/// faces whose snapped sign is not their orientation.
#[test]
fn orientations_of_near_degenerate_faces_follow_the_floats() {
    let mut next = xorshift(0x3c6e_f372_fe94_f82b);
    let mut rand = move || next();
    let mut disagreements = 0;
    for case in 0..24 {
        let f = [4, 3][case % 2];
        let params = RasterParams::new(32, 24, f, 1.0, 0.0).unwrap();
        let magnitude = [10.0, 1e3, 1e5, 1e6][case / 2 % 4];
        let mut screen = Vec::new();
        let blocks = 200;
        for k in 0..blocks * BLOCK {
            let centre = [(rand() - 0.5) * 2.0 * magnitude, (rand() - 0.5) * 2.0 * magnitude];
            let p = if k % BLOCK == (k / BLOCK) % BLOCK {
                // A sliver: the third vertex a small distance off the line of the first two.
                let length = [0.005, 0.05, 0.5, 5.0, 50.0][k % 5] * (0.5 + rand());
                let angle = rand() * std::f64::consts::TAU;
                let d = [length * angle.cos(), length * angle.sin()];
                let (t, off) = (rand(), (rand() - 0.5) * [1e-3, 1e-2, 0.1][k % 3] / length.max(1.0));
                [
                    centre,
                    [centre[0] + d[0], centre[1] + d[1]],
                    [centre[0] + t * d[0] - off * d[1], centre[1] + t * d[1] + off * d[0]],
                ]
            } else {
                let size = 5.0 + 30.0 * rand();
                [centre, [centre[0] + size, centre[1] + 0.3 * size], [centre[0] + 0.2 * size, centre[1] + size]]
            };
            screen.extend(p.map(|q| ScreenVertex { position: [q[0] as f32, q[1] as f32], valid: 1, pad: 0 }));
        }
        let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
        let n = blocks * BLOCK;
        let triangles: Vec<[u32; 3]> = (0..n as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
        for t in &triangles {
            let [a, b, c] = t.map(|i| snapped[i as usize]);
            let w = [a, b, c].map(|p| [p[0] as i64, p[1] as i64]);
            let sign = crate::cpu::coverage::triangle::area2(&w).signum() as i8;
            let q = t.map(|i| screen[i as usize].position);
            disagreements += (sign != crate::cpu::edges::orientation_sign(q[0], q[1], q[2])) as u32;
        }
        let topology = Topology::new(snapped.len(), triangles).unwrap();
        check_fused(&params, &screen, &snapped, &topology, &format!("slivers {case}"));
    }
    assert!(disagreements > 100, "faces whose snapped sign is not their orientation: {disagreements}");
}

/// A face's code keeps its sign and its orientation apart: distinct codes for distinct pairs,
/// the sign read back from each, the sign itself where the two agree.
#[test]
fn face_codes_keep_sign_and_orientation() {
    use super::faces::{code_sign, face_code};
    let mut seen = std::collections::HashSet::new();
    for s in -1..=1i8 {
        for o in -1..=1i8 {
            let code = face_code(s, o);
            assert_eq!(code_sign(code), s, "({s}, {o})");
            assert!(seen.insert(code), "({s}, {o}) shares its code {code}");
            if s == o {
                assert_eq!(code, s);
            }
        }
    }
}

/// The face pass compiled with AVX2 gives the portable pass's bits (the other tests run whichever
/// the processor takes), with and without the orientations: faces of every size (blocks on the
/// f64 path and on the i64 one), slivers whose float orientation the bound leaves open, clipped
/// vertices, and short last blocks.
#[cfg(target_arch = "x86_64")]
#[test]
fn the_avx2_face_pass_gives_the_portable_bits() {
    if !crate::cpu::isa::has_avx2() {
        eprintln!("this processor has no AVX2: nothing to compare");
        return;
    }
    let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
    let mut rand = move || next();
    let params = RasterParams::new(32, 24, 4, 1.0, 0.0).unwrap();
    let mut disagreements = 0;
    for n in (0..=2 * BLOCK + 1).chain([1000, 4003]) {
        let mut screen = Vec::new();
        for k in 0..n {
            let magnitude = [10.0, 1e3, 1e5, 0.9 * COORD_LIMIT as f64][k / BLOCK % 4];
            let centre = [(rand() - 0.5) * 2.0 * magnitude, (rand() - 0.5) * 2.0 * magnitude];
            // Slivers, faces as large as their distance from the image (wide differences at
            // the largest magnitude: the i64 path), and faces of a few pixels.
            let size = [1e-3, magnitude * (0.1 + rand()), 50.0 * (0.1 + rand())][k % 3];
            let (t, off) = (rand(), if k % 3 == 0 { (rand() - 0.5) * 1e-4 } else { size * (rand() - 0.5) });
            let corners = [
                centre,
                [centre[0] + size, centre[1] + 0.7 * size],
                [centre[0] + t * size - off, centre[1] + t * 0.7 * size + off],
            ];
            for (c, q) in corners.iter().enumerate() {
                let valid = !(k % 11 == 5 && c == k % 3);
                screen.push(ScreenVertex { position: q.map(|x| x as f32), valid: valid as u32, pad: 0 });
            }
        }
        let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
        let triangles: Vec<[u32; 3]> = (0..n as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
        let faces = FacePass { snapped: &snapped, screen: &screen, limit: 1 << 20 };
        for orient in [true, false] {
            let run = |avx2: bool| {
                let (mut signs, mut orientation) = (vec![9i8; n], vec![9i8; if orient { n } else { 0 }]);
                let summary = match (avx2, orient) {
                    // SAFETY: the processor runs AVX2 (checked above).
                    (true, true) => unsafe { faces.chunk_avx2::<true>(&triangles, &mut signs, &mut orientation) },
                    (true, false) => unsafe { faces.chunk_avx2::<false>(&triangles, &mut signs, &mut []) },
                    (false, true) => faces.chunk_any::<true>(&triangles, &mut signs, &mut orientation),
                    (false, false) => faces.chunk_any::<false>(&triangles, &mut signs, &mut []),
                };
                (signs, orientation, summary)
            };
            let (avx2, any) = (run(true), run(false));
            assert_eq!(avx2, any, "{n} faces, orientations {orient}");
            if orient {
                disagreements += any.0.iter().zip(&any.1).filter(|(s, o)| s != o).count();
            }
        }
    }
    assert!(disagreements > 10, "faces whose code is not their orientation: {disagreements}");
}

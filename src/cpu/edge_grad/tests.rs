//! Tests of [`edge_grad`](super::edge_grad) against the stage as first written.

use super::*;
use crate::cpu::bin::{self, Bins};
use crate::cpu::edges;
use crate::reference::closed_form::segment_weights;

/// Parameter interval of `[sa, sb]` on `va + s·d` whose outside (`+ε·outward`) is inside triangle
/// `q`, or that `q` takes over as a coincident edge (`yields`, see below). Exact for shared vertices
/// and coincident edges (the products vanish exactly), so a face adjacent to the edge never
/// occludes it.
///
/// An edge of `q` on the segment's line with `q` on the segment's *inside* covers none of its
/// outside; but when it is another mesh edge lying over the same stretch of boundary (a duplicate
/// surface, the front and back outlines of a box seen face-on), the area there moves once, not
/// once per edge. `yields` says that `q` ranks before the segment's edge ([`coincident_rank`]):
/// then the stretch of `q`'s edge counts as removed from this segment. Ranks are a strict order,
/// so of the coincident edges over a stretch, the one that ranks first keeps it and every other
/// one leaves it out.
fn occluded_interval(
    q: [DVec2; 3],
    va: DVec2,
    vb: DVec2,
    outward: DVec2,
    (sa, sb): (f64, f64),
    yields: bool,
) -> Option<(f64, f64)> {
    let cross = |u: DVec2, v: DVec2| u.x * v.y - u.y * v.x;
    let area2 = cross(q[1] - q[0], q[2] - q[0]);
    if area2 == 0.0 {
        return None;
    }
    let o = area2.signum();
    let (mut lo, mut hi) = (sa, sb);
    for k in 0..3 {
        let (qa, qb) = (q[k], q[(k + 1) % 3]);
        let h = |p: DVec2| o * cross(qb - qa, p - qa);
        let alpha = h(va);
        let beta = h(vb) - alpha;
        if beta == 0.0 {
            let inward = o * DVec2::new(-(qb.y - qa.y), qb.x - qa.x);
            if alpha < 0.0 || (alpha == 0.0 && !covers_line(inward.dot(outward), yields)) {
                return None;
            }
        } else if beta > 0.0 {
            lo = lo.max(-alpha / beta);
        } else {
            hi = hi.min(-alpha / beta);
        }
        if hi <= lo {
            return None;
        }
    }
    Some((lo, hi))
}

/// Whether an occluder edge lying on the segment's line, whose inward normal has dot product `dot`
/// with the segment's outward normal, removes the stretch it spans: when its triangle lies on the
/// segment's outside (it covers it), or on the same side when the triangle ranks first among
/// coincident edges (`yields`, see [`occluded_interval`]).
#[inline]
fn covers_line(dot: f64, yields: bool) -> bool {
    dot > 0.0 || (dot < 0.0 && yields)
}

/// The stage as first written: full bins, every listed triangle tested in f64, no early exit.
#[allow(clippy::too_many_arguments)]
fn reference_gradient(
    params: &RasterParams,
    screen: &[ScreenVertex],
    triangles: &[[u32; 3]],
    bins: &Bins,
    d_image: &[f32],
    edge: [u32; 2],
    inside: i32,
    rank: u32,
) -> (EdgeGrad, BackwardStats) {
    let mut stats = BackwardStats::default();
    let Some((va, vb, outward)) = edge_geometry(screen, edge, inside) else {
        return (EdgeGrad::default(), stats);
    };
    let d = vb - va;
    let (mut wa, mut wb) = (0.0f64, 0.0f64);
    let mut segments = Vec::new();
    let mut s = (0.0, 1.0);
    if !(clip_parameter(va.x, d.x, 0.0, params.width as f64, &mut s)
        && clip_parameter(va.y, d.y, 0.0, params.height as f64, &mut s))
    {
        return (EdgeGrad::default(), stats);
    }
    let (y0, y1) = (va.y + s.0 * d.y, va.y + s.1 * d.y);
    for i in (y0.min(y1).ceil() as i64 - 1).max(0)..=(y0.max(y1).floor() as i64).min(params.height as i64 - 1) {
        let mut r = s;
        if !clip_parameter(va.y, d.y, i as f64, i as f64 + 1.0, &mut r) {
            continue;
        }
        let (x0, x1) = (va.x + r.0 * d.x, va.x + r.1 * d.x);
        for j in (x0.min(x1).ceil() as i64 - 1).max(0)..=(x0.max(x1).floor() as i64).min(params.width as i64 - 1) {
            let mut c = r;
            if clip_parameter(va.x, d.x, j as f64, j as f64 + 1.0, &mut c) && c.1 > c.0 {
                let on_border = (d.y == 0.0 && (va.y == i as f64 || va.y == i as f64 + 1.0))
                    || (d.x == 0.0 && (va.x == j as f64 || va.x == j as f64 + 1.0));
                segments.push((i, j, c, on_border));
            }
        }
    }
    let scale = (params.inside - params.outside) as f64;
    for (i, j, c, on_border) in segments {
        let g =
            d_image[i as usize * params.width as usize + j as usize] as f64 * scale * if on_border { 0.5 } else { 1.0 };
        if g == 0.0 {
            continue;
        }
        stats.segments += 1;
        let (lo, hi) = (va + c.0 * d, va + c.1 * d);
        let (lo, hi) = (lo.min(hi), lo.max(hi));
        let mut found = Vec::new();
        let tile = (i as u32 / params.tile_size) * params.tiles_x + j as u32 / params.tile_size;
        for (t, b, _) in bins.tile(tile as usize) {
            let b = [b[0], b[1], -b[2], -b[3]].map(|x| x as f64);
            if b[0] > hi.x || b[1] > hi.y || b[2] < lo.x || b[3] < lo.y {
                continue;
            }
            let q = triangles[t as usize].map(|v| position(screen, v));
            found.extend(occluded_interval(q, va, vb, outward, c, t < rank));
        }
        found.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let (mut visible_a, mut visible_b, mut cursor) = (0.0, 0.0, c.0);
        for &(lo, hi) in found.iter().chain(std::iter::once(&(c.1, c.1))) {
            if lo > cursor {
                let [ka, kb] = segment_weights(cursor, lo);
                visible_a += ka;
                visible_b += kb;
            }
            cursor = cursor.max(hi);
        }
        if visible_a != 0.0 || visible_b != 0.0 {
            stats.visible_segments += 1;
        }
        wa += g * visible_a;
        wb += g * visible_b;
    }
    let (ga, gb) = (outward * wa, outward * wb);
    (EdgeGrad { a: [ga.x as f32, ga.y as f32], b: [gb.x as f32, gb.y as f32] }, stats)
}

/// Runs the stage on a scene and asserts that every slot is the reference's within the rounding
/// of the visible intervals' ends (see [`edge_grad`]) and that the statistics are the
/// reference's; returns the statistics and how many slots are the reference's bits.
fn compare_with_reference(
    params: &RasterParams,
    screen: &[ScreenVertex],
    topology: &Topology,
    d_image: &[f32],
    what: &str,
) -> (BackwardStats, usize) {
    let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
    let mut orientation = vec![0i8; topology.triangles().len()];
    edges::face_orientations(screen, topology.triangles(), &mut orientation);
    let mut candidates = Vec::new();
    edges::edges(&orientation, topology, &mut candidates);
    let mut slots = Vec::new();
    let mut scratch = EdgeGradScratch::default();
    let stats = edge_grad(params, screen, &orientation, topology, &candidates, d_image, &mut slots, &mut scratch);
    let mut full = Bins::default();
    bin::bin(params, screen, &snapped, topology.triangles(), &mut full);
    let mut expected = BackwardStats::default();
    let mut reference = Vec::new();
    for &(e, side) in &candidates {
        let edge = topology.edges()[e as usize];
        let rank = coincident_rank(&orientation, topology, e);
        let (grad, s) = reference_gradient(params, screen, topology.triangles(), &full, d_image, edge, side, rank);
        reference.push(grad);
        expected = expected + s;
    }
    let components = |g: &EdgeGrad| [g.a[0], g.a[1], g.b[0], g.b[1]];
    let largest = reference.iter().flat_map(components).fold(0.0f32, |m, x| m.max(x.abs()));
    let mut same = 0;
    for ((&(e, _), slot), expected) in candidates.iter().zip(&slots).zip(&reference) {
        for (x, r) in components(slot).into_iter().zip(components(expected)) {
            let tolerance = 2e-7 * r.abs() + 1e-9 * largest;
            assert!((x - r).abs() <= tolerance, "{what} edge {e}: {slot:?} against {expected:?}");
        }
        same += (slot == expected) as usize;
    }
    assert_eq!(stats, expected, "{what}");
    (stats, same)
}

/// Two dense overlapping spheres in a small image: each sphere hides part of the other's outline,
/// and hundreds of triangles lie in each pixel; the stage must give the reference's gradients.
#[test]
fn dense_overlap_as_the_reference() {
    let sphere = crate::scene::shapes::icosphere(4);
    let n = sphere.positions().len() as u32;
    let pair = crate::scene::mesh::Mesh::new(
        sphere
            .positions()
            .iter()
            .copied()
            .chain(sphere.positions().iter().map(|p| *p * 0.8 + glam::Vec3::new(0.7, 0.4, 0.5)))
            .collect(),
        sphere.triangles().iter().copied().chain(sphere.triangles().iter().map(|t| t.map(|v| v + n))).collect(),
    )
    .unwrap();
    let (w, h) = (12, 10);
    let mut params = RasterParams::new(w, h, 4, 1.0, 0.0).unwrap();
    params.set_tile_size(4);
    let screen: Vec<ScreenVertex> = pair
        .positions()
        .iter()
        .map(|p| {
            let (x, y) = (p.x as f64 + 0.2 * p.z as f64, p.y as f64 - 0.3 * p.z as f64);
            let q = [w as f64 * (0.35 + 0.3 * x), h as f64 * (0.4 + 0.3 * y)];
            ScreenVertex { position: q.map(|c| c as f32), valid: 1, pad: 0 }
        })
        .collect();
    let d_image: Vec<f32> = (0..params.pixel_count()).map(|k| 0.25 + (k % 7) as f32 * 0.1).collect();
    let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
    let mut full = Bins::default();
    bin::bin(&params, &screen, &snapped, pair.triangles(), &mut full);
    let longest = (0..params.tiles_x * params.tiles_y).map(|t| full.tile(t as usize).count()).max().unwrap();
    assert!(longest > 256, "lists of at most {longest} entries");
    let (stats, same) = compare_with_reference(&params, &screen, pair.topology(), &d_image, "two dense spheres");
    assert!(same > 0, "no slot with the reference's bits");
    assert!(stats.segments > stats.visible_segments, "no hidden segment: {stats:?}");
    assert!(stats.visible_segments > 0, "no visible segment: {stats:?}");
}

/// The stage (visibility from the contour) gives the reference's gradients (the triangles of
/// each pixel tested one by one), on random folded meshes with overlaps, ties on pixel
/// borders, meshes over the image's borders, coincident edges (a mesh with a copy of itself), open meshes (holes, flipped faces,
/// half a sphere: their oriented boundary keeps the back faces near it) and a sparse `∂L/∂I`.
#[test]
fn same_bits_as_the_reference() {
    let mut seed = 0x6a09_e667_f3bc_c908u64;
    let mut rand = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let single = crate::scene::shapes::icosphere(2);
    // The sphere and an exact copy of it: every silhouette edge coincides with its copy's.
    let n = single.positions().len() as u32;
    let doubled = crate::scene::mesh::Mesh::new(
        single.positions().iter().chain(single.positions()).copied().collect(),
        // Interleaved, so that the faces of an edge and of its copy alternate in index order: a
        // copy's rank face is then often a negative one below the other edge's positive face.
        single.triangles().iter().flat_map(|&t| [t, t.map(|v| v + n)]).collect(),
    )
    .unwrap();
    let (mut hidden, mut slots_same, mut slots) = (0, 0, 0);
    for case in 0..60 {
        let (w, h) = (20 + case % 7, 16 + case % 5);
        let mut params = RasterParams::new(w, h, 4, 1.0, 0.0).unwrap();
        params.set_tile_size([1, 2, 4][case as usize % 3]);
        let m = [rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0, rand() * 2.0 - 1.0];
        let mut damaged = single.triangles().to_vec();
        crate::cpu::coverage::damage(&mut damaged, 1 + case as usize / 3 % 3, &mut rand);
        let damaged = Topology::new(single.positions().len(), damaged).unwrap();
        let topology = match case % 3 {
            0 => single.topology(),
            1 => doubled.topology(),
            _ => &damaged,
        };
        // Every fifth case spills over the image's borders: edges start outside it.
        let spread = if case % 5 == 3 { 0.9 } else { 0.45 };
        let mut screen: Vec<ScreenVertex> = single
            .positions()
            .iter()
            .map(|p| {
                let (x, y) = (p.x as f64, p.y as f64 + 0.3 * p.z as f64);
                let mut q = [
                    w as f64 * (0.5 + spread * (m[0] * x + m[1] * y)) + 0.3 * (rand() - 0.5),
                    h as f64 * (0.5 + spread * (m[2] * x + m[3] * y)) + 0.3 * (rand() - 0.5),
                ];
                if case % 4 == 0 {
                    q = q.map(|c| (c * 2.0).round() / 2.0); // on pixel borders and centres
                }
                ScreenVertex { position: q.map(|c| c as f32), valid: 1, pad: 0 }
            })
            .collect();
        if case % 3 == 1 {
            screen.extend_from_within(..);
        }
        let d_image: Vec<f32> =
            (0..params.pixel_count()).map(|_| if rand() < 0.3 { 0.0 } else { (rand() * 2.0 - 1.0) as f32 }).collect();
        let (stats, same) = compare_with_reference(&params, &screen, topology, &d_image, &format!("case {case}"));
        hidden += stats.segments - stats.visible_segments;
        (slots_same, slots) = (slots_same + same, slots + stats.segments as usize);
    }
    assert!(hidden > 100, "too few hidden segments ({hidden})");
    println!("{slots_same} slots the reference's bits ({slots} segments)");
}

#[test]
fn inline_floor_and_ceil_equal_the_standard_ones() {
    let mut values = vec![0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.5, -2.5, 63.999_999, 64.0, 1e-300, -1e-300];
    values.extend([
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::MAX,
        f64::MIN,
        4_503_599_627_370_495.5,
        -4_503_599_627_370_495.5,
    ]);
    values.extend([4_503_599_627_370_496.0, 9.3e18, -9.3e18, 1e30, f64::MIN_POSITIVE, f64::EPSILON]);
    let mut rng = crate::random::SplitMix64::new(3);
    values.extend((0..10_000).map(|_| rng.range(-1e4, 1e4) as f64));
    for x in values {
        assert_eq!(floor(x), x.floor(), "floor({x:e})");
        assert_eq!(ceil(x), x.ceil(), "ceil({x:e})");
        assert_eq!(floor(x) as i64, x.floor() as i64, "floor({x:e}) as i64");
    }
    assert!(floor(f64::NAN).is_nan() && ceil(f64::NAN).is_nan());
}

/// The one-pixel shortcut of [`edge_segments`] finds what the walk finds: edges inside a pixel,
/// on its borders and corners (horizontal and vertical ones among them, whose segments on a
/// border are halved), across pixels, partly or wholly off the image, over pixels with zero and
/// non-zero `∂L/∂I`.
#[test]
fn one_pixel_segments_are_the_walks() {
    let mut rng = crate::random::SplitMix64::new(11);
    let params = RasterParams::new(7, 5, 4, 1.0, 0.0).unwrap();
    let d_image: Vec<f32> = (0..35).map(|k| if k % 3 == 0 { 0.0 } else { rng.range(-1.0, 1.0) }).collect();
    let (mut shortcut, mut walked) = (Vec::new(), Vec::new());
    let mut inside = 0;
    for case in 0..20_000 {
        let snap = |x: f64| if case % 4 == 0 { (x * 4.0).round() / 4.0 } else { x };
        let start = [snap(rng.range(-1.5, 8.5) as f64), snap(rng.range(-1.5, 6.5) as f64)];
        let length = [0.05, 0.3, 1.0, 3.0][case % 4 / 2 + case % 3 % 2];
        let mut d = [rng.range(-1.0, 1.0) as f64 * length, rng.range(-1.0, 1.0) as f64 * length];
        match case % 7 {
            0 => d[0] = 0.0,
            1 => d[1] = 0.0,
            _ => {}
        }
        let (va, vb) = (DVec2::from(start), DVec2::from(start) + DVec2::from(d));
        if va == vb {
            continue;
        }
        shortcut.clear();
        walked.clear();
        edge_segments(&params, &d_image, va, vb, &mut shortcut);
        walk_segments(&params, &d_image, va, vb, &mut walked);
        let same = shortcut.len() == walked.len()
            && shortcut.iter().zip(&walked).all(|(a, b)| a.s.0 == b.s.0 && a.s.1 == b.s.1 && a.g == b.g);
        assert!(same, "{va} → {vb}: {shortcut:?} against {walked:?}");
        let (lo, hi) = (va.min(vb), va.max(vb));
        inside += (lo.floor() == hi.floor() && walked.len() == 1) as u32;
    }
    assert!(inside > 1000, "edges inside one pixel with a gradient: {inside}");
}

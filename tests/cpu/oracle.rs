//! Tests of the exact-area coverage oracle (`diffsil::reference::oracle`) against hand-computed areas,
//! an independent inclusion–exclusion over convex polygon intersections, and brute-force
//! point sampling.

use diffsil::reference::oracle::{exact_coverage, exact_image};
use glam::Vec2;

use crate::common::rng::{Draws, SplitMix64};

// ---------------------------------------------------------------------------------------------
// Independent references
// ---------------------------------------------------------------------------------------------

/// A coordinate uniform in `[lo, hi)`, drawn in f64 and rounded to f32.
fn coord(rng: &mut SplitMix64, lo: f64, hi: f64) -> f32 {
    rng.range_f64(lo, hi) as f32
}

type P = [f64; 2];

fn tri_pts(v: &[Vec2], t: [u32; 3]) -> [P; 3] {
    t.map(|k| [v[k as usize].x as f64, v[k as usize].y as f64])
}

fn shoelace(p: &[P]) -> f64 {
    let mut s = 0.0;
    for k in 0..p.len() {
        let (a, b) = (p[k], p[(k + 1) % p.len()]);
        s += a[0] * b[1] - a[1] * b[0];
    }
    0.5 * s.abs()
}

fn cross(o: P, a: P, b: P) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Clips a polygon to the half-plane on the left of a→b (`cross(a, b, p) >= 0`).
fn clip_left(poly: &[P], a: P, b: P) -> Vec<P> {
    let mut out = Vec::new();
    for k in 0..poly.len() {
        let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
        let (dp, dq) = (cross(a, b, p), cross(a, b, q));
        if dp >= 0.0 {
            out.push(p);
        }
        if (dp >= 0.0) != (dq >= 0.0) {
            let t = dp / (dp - dq);
            out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
        }
    }
    out
}

/// Intersects a convex polygon with a triangle (either winding).
fn clip_to_triangle(poly: Vec<P>, t: [P; 3]) -> Vec<P> {
    let t = if cross(t[0], t[1], t[2]) < 0.0 { [t[0], t[2], t[1]] } else { t };
    let mut poly = poly;
    for k in 0..3 {
        if poly.is_empty() {
            break;
        }
        poly = clip_left(&poly, t[k], t[(k + 1) % 3]);
    }
    poly
}

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<P> {
    vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
}

/// Area of (union of triangles) ∩ region, by inclusion–exclusion over all subsets: exact, and a
/// method independent of the slab method. Degenerate triangles must be filtered out first.
fn union_area_incl_excl(tris: &[[P; 3]], region: &[P]) -> f64 {
    let n = tris.len();
    assert!(n <= 12, "inclusion–exclusion is exponential");
    let mut total = 0.0;
    for mask in 1u32..(1 << n) {
        let mut poly = region.to_vec();
        for (k, t) in tris.iter().enumerate() {
            if mask & (1 << k) != 0 {
                poly = clip_to_triangle(poly, *t);
                if poly.len() < 3 {
                    break;
                }
            }
        }
        if poly.len() >= 3 {
            let sign = if mask.count_ones() % 2 == 1 { 1.0 } else { -1.0 };
            total += sign * shoelace(&poly);
        }
    }
    total
}

fn in_triangle(t: [P; 3], p: P) -> bool {
    let (d0, d1, d2) = (cross(t[0], t[1], p), cross(t[1], t[2], p), cross(t[2], t[0], p));
    (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0)
}

/// Fraction of an n×n grid of sample points in pixel (i, j) covered by any triangle.
fn sampled_pixel(tris: &[[P; 3]], i: u32, j: u32, n: u32) -> f64 {
    let near: Vec<[P; 3]> = tris
        .iter()
        .copied()
        .filter(|t| {
            let (xmin, xmax) = (
                t.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
                t.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
            );
            let (ymin, ymax) = (
                t.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min),
                t.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max),
            );
            xmax >= j as f64 && xmin <= j as f64 + 1.0 && ymax >= i as f64 && ymin <= i as f64 + 1.0
        })
        .collect();
    let mut hits = 0u64;
    for a in 0..n {
        for b in 0..n {
            let p = [j as f64 + (a as f64 + 0.5) / n as f64, i as f64 + (b as f64 + 0.5) / n as f64];
            if near.iter().any(|&t| in_triangle(t, p)) {
                hits += 1;
            }
        }
    }
    hits as f64 / (n * n) as f64
}

/// Two triangles for the axis-aligned rectangle [x0, x1] × [y0, y1], appended to a soup.
fn push_rect(v: &mut Vec<Vec2>, t: &mut Vec<[u32; 3]>, x0: f32, y0: f32, x1: f32, y1: f32) {
    let b = v.len() as u32;
    v.extend([Vec2::new(x0, y0), Vec2::new(x1, y0), Vec2::new(x1, y1), Vec2::new(x0, y1)]);
    t.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
}

fn at(img: &[f64], w: u32, i: u32, j: u32) -> f64 {
    img[(i * w + j) as usize]
}

/// Random triangle soup: `n` triangles with centres in `[lo, hi]²` and vertices within `r`.
fn random_soup(rng: &mut SplitMix64, n: usize, lo: f64, hi: f64, r: f64) -> (Vec<Vec2>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    let mut t = Vec::new();
    for k in 0..n {
        let c = (coord(rng, lo, hi) as f64, coord(rng, lo, hi) as f64);
        for _ in 0..3 {
            v.push(Vec2::new(coord(rng, c.0 - r, c.0 + r), coord(rng, c.1 - r, c.1 + r)));
        }
        let b = 3 * k as u32;
        t.push([b, b + 1, b + 2]);
    }
    (v, t)
}

// ---------------------------------------------------------------------------------------------
// Tests
// ---------------------------------------------------------------------------------------------

#[test]
fn triangle_inside_one_pixel_has_its_shoelace_area() {
    let v = [Vec2::new(3.1, 2.2), Vec2::new(3.9, 2.3), Vec2::new(3.4, 2.95)];
    let tris = [[0, 1, 2]];
    let expected = shoelace(&tri_pts(&v, tris[0]));
    let img = exact_coverage(&v, &tris, 8, 6);
    assert_eq!(img.len(), 48);
    for i in 0..6 {
        for j in 0..8 {
            let c = at(&img, 8, i, j);
            if (i, j) == (2, 3) {
                assert!((c - expected).abs() < 1e-12, "pixel (2,3): {c} vs shoelace {expected}");
            } else {
                assert_eq!(c, 0.0, "pixel ({i},{j})");
            }
        }
    }
    // Either winding.
    let img2 = exact_coverage(&v, &[[0, 2, 1]], 8, 6);
    assert_eq!(img, img2);
}

#[test]
fn aligned_square_covers_whole_pixels() {
    let (mut v, mut t) = (Vec::new(), Vec::new());
    push_rect(&mut v, &mut t, 2.0, 1.0, 5.0, 4.0);
    let img = exact_coverage(&v, &t, 8, 6);
    for i in 0..6 {
        for j in 0..8 {
            let inside = (2..5).contains(&j) && (1..4).contains(&i);
            let c = at(&img, 8, i, j);
            assert!((c - if inside { 1.0 } else { 0.0 }).abs() < 1e-12, "pixel ({i},{j}) = {c}");
        }
    }
}

#[test]
fn half_pixel_offset_square_gives_quarters_and_halves() {
    let (mut v, mut t) = (Vec::new(), Vec::new());
    // [2.5, 5.5] × [1.5, 4.5]: columns 2..=5, rows 1..=4 touched.
    push_rect(&mut v, &mut t, 2.5, 1.5, 5.5, 4.5);
    let img = exact_coverage(&v, &t, 8, 6);
    for i in 0..6u32 {
        for j in 0..8u32 {
            let fx = match j {
                2 | 5 => 0.5,
                3 | 4 => 1.0,
                _ => 0.0,
            };
            let fy = match i {
                1 | 4 => 0.5,
                2 | 3 => 1.0,
                _ => 0.0,
            };
            let c = at(&img, 8, i, j);
            assert!((c - fx * fy).abs() < 1e-12, "pixel ({i},{j}) = {c}, expected {}", fx * fy);
        }
    }
    let total: f64 = img.iter().sum();
    assert!((total - 9.0).abs() < 1e-11);
}

#[test]
fn overlapping_squares_count_once() {
    // A = [1, 5.5]² (4.5²), B = [3.25, 8.5] × [2.75, 6.5] (5.25 × 3.75),
    // A ∩ B = [3.25, 5.5] × [2.75, 5.5] (2.25 × 2.75).
    let (mut v, mut t) = (Vec::new(), Vec::new());
    push_rect(&mut v, &mut t, 1.0, 1.0, 5.5, 5.5);
    push_rect(&mut v, &mut t, 3.25, 2.75, 8.5, 6.5);
    let img = exact_coverage(&v, &t, 10, 8);
    let total: f64 = img.iter().sum();
    let expected = 4.5 * 4.5 + 5.25 * 3.75 - 2.25 * 2.75;
    assert!((total - expected).abs() < 1e-11, "union {total} vs {expected}");
    // Pixel [3, 4] × [5, 6]: A covers 1 × 0.5, B covers 0.75 × 1, both 0.75 × 0.5.
    let c = at(&img, 10, 5, 3);
    assert!((c - 0.875).abs() < 1e-12, "{c}");
    // Pixel [4, 5] × [3, 4] lies inside both: 1, not 2.
    assert!((at(&img, 10, 3, 4) - 1.0).abs() < 1e-12);
    assert!(img.iter().all(|&c| (0.0..=1.0).contains(&c)));
}

#[test]
fn overlapping_slanted_triangles_count_once() {
    // A = (1,1),(9,1),(1,9): area 32. B = (1,1),(9,1),(9,9): area 32. A ∩ B = (1,1),(9,1),(5,5):
    // area 16. Union = 48. Shifted by a non-grid offset so edges cut pixels generically.
    let o = Vec2::new(0.3, 0.45);
    let v = [Vec2::new(1.0, 1.0) + o, Vec2::new(9.0, 1.0) + o, Vec2::new(1.0, 9.0) + o, Vec2::new(9.0, 9.0) + o];
    let t = [[0, 1, 2], [0, 1, 3]];
    let img = exact_coverage(&v, &t, 12, 12);
    let total: f64 = img.iter().sum();
    assert!((total - 48.0).abs() < 1e-10, "union {total} vs 48");
    // Per pixel against inclusion–exclusion.
    let pts: Vec<[P; 3]> = t.iter().map(|&k| tri_pts(&v, k)).collect();
    for i in 0..12 {
        for j in 0..12 {
            let r = union_area_incl_excl(&pts, &rect(j as f64, i as f64, j as f64 + 1.0, i as f64 + 1.0));
            let c = at(&img, 12, i, j);
            assert!((c - r).abs() < 1e-12, "pixel ({i},{j}): {c} vs {r}");
        }
    }
}

#[test]
fn random_soup_matches_inclusion_exclusion_and_sampling() {
    let (w, h) = (16u32, 16u32);
    let mut rng = SplitMix64::new(0x5EED_0001);
    for round in 0..4 {
        // Eight triangles of mixed sizes, some crossing the border.
        let r = [1.5, 3.0, 5.0, 8.0][round];
        let (v, t) = random_soup(&mut rng, 8, -2.0, 18.0, r);
        let img = exact_coverage(&v, &t, w, h);
        let pts: Vec<[P; 3]> = t.iter().map(|&k| tri_pts(&v, k)).filter(|p| cross(p[0], p[1], p[2]) != 0.0).collect();

        // Total against the exact union area inside the image.
        let total: f64 = img.iter().sum();
        let union = union_area_incl_excl(&pts, &rect(0.0, 0.0, w as f64, h as f64));
        assert!((total - union).abs() < 1e-9, "round {round}: total {total} vs union {union}");

        let mut worst_sampled = 0.0f64;
        for i in 0..h {
            for j in 0..w {
                let c = at(&img, w, i, j);
                assert!((0.0..=1.0).contains(&c));
                // Exact, per pixel.
                let exact = union_area_incl_excl(&pts, &rect(j as f64, i as f64, j as f64 + 1.0, i as f64 + 1.0));
                assert!((c - exact).abs() < 1e-12, "round {round}, pixel ({i},{j}): {c} vs {exact}");
                // Brute force, 64×64 samples per pixel.
                let s = sampled_pixel(&pts, i, j, 64);
                worst_sampled = worst_sampled.max((c - s).abs());
                assert!((c - s).abs() < 2e-3, "round {round}, pixel ({i},{j}): {c} vs sampled {s}");
            }
        }
        eprintln!("round {round}: union {union:.6}, worst |exact - 64x64 sampled| = {worst_sampled:.2e}");

        // Total against very fine sampling (256×256 per pixel) over the image.
        let sampled_total: f64 =
            (0..h).flat_map(|i| (0..w).map(move |j| (i, j))).map(|(i, j)| sampled_pixel(&pts, i, j, 256)).sum();
        eprintln!("round {round}: |total - 256x256 sampled total| = {:.2e}", (total - sampled_total).abs());
        assert!((total - sampled_total).abs() < 1e-3, "round {round}: {total} vs sampled {sampled_total}");
    }
}

#[test]
fn many_small_triangles_match_references() {
    let (w, h) = (64u32, 64u32);
    let mut rng = SplitMix64::new(42);
    let (v, t) = random_soup(&mut rng, 5000, -1.0, 65.0, 1.2);
    let img = exact_coverage(&v, &t, w, h);
    assert!(img.iter().all(|&c| (0.0..=1.0).contains(&c)));
    let pts: Vec<[P; 3]> = t.iter().map(|&k| tri_pts(&v, k)).filter(|p| cross(p[0], p[1], p[2]) != 0.0).collect();
    let (mut worst, mut exact_checked) = (0.0f64, 0);
    for k in 0..64u32 {
        let (i, j) = ((k * 37 + 5) % h, (k * 11 + 3) % w);
        let c = at(&img, w, i, j);
        // Exact where few enough triangles touch the pixel for inclusion–exclusion.
        let pixel = rect(j as f64, i as f64, j as f64 + 1.0, i as f64 + 1.0);
        let near: Vec<[P; 3]> =
            pts.iter().copied().filter(|&t| clip_to_triangle(pixel.clone(), t).len() >= 3).collect();
        if near.len() <= 12 {
            let exact = union_area_incl_excl(&near, &pixel);
            assert!((c - exact).abs() < 1e-12, "pixel ({i},{j}), {} triangles: {c} vs {exact}", near.len());
            exact_checked += 1;
        }
        // Fine sampling, 256×256 per pixel.
        let s = sampled_pixel(&near, i, j, 256);
        worst = worst.max((c - s).abs());
        assert!((c - s).abs() < 1e-3, "pixel ({i},{j}): {c} vs sampled {s}");
    }
    assert!(exact_checked >= 32, "only {exact_checked} pixels checked exactly");
    eprintln!("5000 triangles: {exact_checked}/64 pixels exact; worst |exact - 256x256 sampled| = {worst:.2e}");
}

#[test]
fn snapped_and_shared_vertex_soups_match_inclusion_exclusion() {
    // Degenerate-prone input: vertices snapped to half-pixels (vertices on pixel corners, edges
    // along pixel borders, collinear overlapping edges) and triangles sharing vertices.
    for seed in 0..200u64 {
        let mut rng = SplitMix64::new(seed);
        let (mut v, mut t) = (Vec::new(), Vec::new());
        for k in 0..6u32 {
            for _ in 0..3 {
                let (mut x, mut y) = (coord(&mut rng, -1.0, 9.0), coord(&mut rng, -1.0, 9.0));
                if seed % 2 == 0 {
                    (x, y) = ((x * 2.0).round() / 2.0, (y * 2.0).round() / 2.0);
                }
                v.push(Vec2::new(x, y));
            }
            let b = 3 * k;
            t.push(if k > 0 && seed % 3 == 0 { [b - 1, b - 2, b + 2] } else { [b, b + 1, b + 2] });
        }
        let img = exact_coverage(&v, &t, 8, 8);
        let pts: Vec<[P; 3]> = t.iter().map(|&k| tri_pts(&v, k)).filter(|p| cross(p[0], p[1], p[2]) != 0.0).collect();
        for i in 0..8 {
            for j in 0..8 {
                let e = union_area_incl_excl(&pts, &rect(j as f64, i as f64, j as f64 + 1.0, i as f64 + 1.0));
                let c = at(&img, 8, i, j);
                assert!((c - e).abs() < 1e-12, "seed {seed}, pixel ({i},{j}): {c} vs {e}");
            }
        }
    }
}

#[test]
fn triangle_crossing_the_border_counts_only_its_inside_part() {
    // Hypotenuse x + y = 4; inside the image it is (0,0),(4,0),(0,4): area 8.
    let v = [Vec2::new(-2.0, -2.0), Vec2::new(6.0, -2.0), Vec2::new(-2.0, 6.0)];
    let img = exact_coverage(&v, &[[0, 1, 2]], 8, 8);
    let total: f64 = img.iter().sum();
    assert!((total - 8.0).abs() < 1e-12, "{total}");
    assert!((at(&img, 8, 0, 3) - 0.5).abs() < 1e-12); // diagonal pixel: half
    assert!((at(&img, 8, 1, 1) - 1.0).abs() < 1e-12);

    // Fully outside: nothing. Covering the whole image: all ones.
    let out = [Vec2::new(-5.0, -5.0), Vec2::new(-1.0, -5.0), Vec2::new(-1.0, 20.0)];
    assert!(exact_coverage(&out, &[[0, 1, 2]], 8, 8).iter().all(|&c| c == 0.0));
    let big = [Vec2::new(-100.0, -100.0), Vec2::new(300.0, -100.0), Vec2::new(-100.0, 300.0)];
    assert!(exact_coverage(&big, &[[0, 1, 2]], 8, 8).iter().all(|&c| c == 1.0));
}

#[test]
fn zero_area_triangles_give_zero() {
    let v = [Vec2::new(1.0, 1.0), Vec2::new(5.5, 5.5), Vec2::new(3.25, 3.25), Vec2::new(2.0, 6.0)];
    // Collinear, and a repeated vertex.
    let img = exact_coverage(&v, &[[0, 1, 2], [3, 3, 1], [0, 0, 0]], 8, 8);
    assert!(img.iter().all(|&c| c == 0.0), "{img:?}");
}

#[test]
fn duplicate_and_reversed_triangles_do_not_double() {
    let v = [Vec2::new(0.7, 0.2), Vec2::new(6.3, 1.9), Vec2::new(2.2, 5.6)];
    let once = exact_coverage(&v, &[[0, 1, 2]], 8, 8);
    let thrice = exact_coverage(&v, &[[0, 1, 2], [0, 1, 2], [2, 1, 0]], 8, 8);
    for (a, b) in once.iter().zip(&thrice) {
        assert!((a - b).abs() < 1e-12, "{a} vs {b}");
    }
    let total: f64 = once.iter().sum();
    let area = shoelace(&tri_pts(&v, [0, 1, 2]));
    assert!((total - area).abs() < 1e-12, "{total} vs {area}");
}

#[test]
fn shared_edge_neither_gaps_nor_doubles() {
    // A quad split along a slanted diagonal: every pixel sees two triangles meeting on an edge.
    let v = [Vec2::new(0.5, 0.25), Vec2::new(7.25, 0.75), Vec2::new(6.5, 7.5), Vec2::new(1.0, 6.75)];
    let img = exact_coverage(&v, &[[0, 1, 2], [0, 2, 3]], 8, 8);
    let quad = shoelace(&[[0.5, 0.25], [7.25, 0.75], [6.5, 7.5], [1.0, 6.75]]);
    let total: f64 = img.iter().sum();
    assert!((total - quad).abs() < 1e-11, "{total} vs {quad}");
    assert!((at(&img, 8, 3, 3) - 1.0).abs() < 1e-12, "interior pixel on the diagonal");
}

#[test]
fn non_finite_triangles_are_skipped() {
    let v = [
        Vec2::new(1.0, 1.0),
        Vec2::new(3.0, 1.0),
        Vec2::new(1.0, 3.0),
        Vec2::new(f32::NAN, 2.0),
        Vec2::new(f32::INFINITY, 0.0),
    ];
    let img = exact_coverage(&v, &[[0, 1, 2], [0, 1, 3], [4, 1, 2]], 4, 4);
    assert!(img.iter().all(|c| c.is_finite()));
    let total: f64 = img.iter().sum();
    assert!((total - 2.0).abs() < 1e-12, "{total}");
}

#[test]
fn exact_image_maps_coverage_to_values() {
    let (mut v, mut t) = (Vec::new(), Vec::new());
    push_rect(&mut v, &mut t, 0.5, 0.0, 2.0, 1.0);
    let img = exact_image(&v, &t, 3, 1, 0.75, 0.25);
    let expected = [0.25 + 0.5 * 0.5, 0.75, 0.25];
    for (a, b) in img.iter().zip(expected) {
        assert!((a - b).abs() < 1e-12, "{img:?}");
    }
    assert!(exact_coverage(&v, &t, 0, 5).is_empty());
    assert!(exact_coverage(&v, &t, 5, 0).is_empty());
}

//! The closed-form pixel-area derivative of ARCHITECTURE.md, *The method* (`closed_form::pixel_area_gradient`)
//! against the paper's formulation (Wu, Jiang, Yu 2020, Eqs. 12–16) and against finite
//! differences of the exact triangle ∩ pixel area.
//!
//! # The paper-style form used here
//!
//! The paper's text was not available while writing this test, so [`paper_gradient`] is an
//! independent derivation in the paper's parametrisation, not a transcription. An edge from
//! `v0 = (x0, y0)` to `v1 = (x1, y1)` lies on the line `α(x, y) = A x + B y + C = 0` with
//! `A = y1 − y0`, `B = x0 − x1`, `C = x1 y0 − x0 y1`; the covered region is on the `α < 0` side
//! (for a triangle: orient it so its interior is on that side of all three edges). Points of the
//! line are parametrised by `k = −B x + A y`:
//!
//! ```text
//! x(k) = (−B k − A C) / N,   y(k) = (A k − B C) / N,   N = A² + B²,   dl = dk / √N,
//! ```
//!
//! with `k` increasing from `v0` to `v1`. Clipping the edge to the pixel gives `[k0, k1]`. Moving
//! the line changes the area of `{α < 0} ∩ pixel` by the flux through the clipped edge, with
//! normal velocity `−(∂α/∂θ)/|∇α|`, so
//!
//! ```text
//! ∂S/∂C = −(k1 − k0) / N
//! ∂S/∂A = −(1/N) ∫ x(k) dk = −[ −B (k1² − k0²)/2 − A C (k1 − k0) ] / N²
//! ∂S/∂B = −(1/N) ∫ y(k) dk = −[  A (k1² − k0²)/2 − B C (k1 − k0) ] / N²
//! ```
//!
//! and the vertex derivatives follow through `A, B, C`:
//! `∂/∂x0 = ∂S/∂B − y1 ∂S/∂C`, `∂/∂y0 = −∂S/∂A + x1 ∂S/∂C`, `∂/∂x1 = −∂S/∂B + y0 ∂S/∂C`,
//! `∂/∂y1 = ∂S/∂A − x0 ∂S/∂C`. A zero-length edge (`N = 0`) contributes nothing. The clip here is
//! done on `k` (the line's own parameter), not with the crate's Liang–Barsky on `s`.

use crate::common::fd::{symmetric_pair, Rng};
use diffsil::reference::closed_form::{clip_parameter, pixel_area_gradient, segment_weights};
use diffsil::reference::oracle::exact_coverage;
use glam::{DVec2, Vec2};

/// The derivative of the area of pixel (`row`, `col`) on the `α < 0` side of the clipped edge
/// `v0 → v1`, by the paper-style A/B/C/k form above: `[∂S/∂v0, ∂S/∂v1]`.
fn paper_gradient(v0: DVec2, v1: DVec2, row: i64, col: i64) -> [DVec2; 2] {
    let (x0, y0, x1, y1) = (v0.x, v0.y, v1.x, v1.y);
    let (a, b, c) = (y1 - y0, x0 - x1, x1 * y0 - x0 * y1);
    let n = a * a + b * b;
    if n == 0.0 {
        return [DVec2::ZERO; 2];
    }
    let k_of = |p: DVec2| -b * p.x + a * p.y;
    let (mut k0, mut k1) = (k_of(v0), k_of(v1));
    // x(k) ∈ [col, col + 1] and y(k) ∈ [row, row + 1] as ranges of k.
    let mut restrict = |coef: f64, offset: f64, lo: f64, hi: f64| -> bool {
        // value(k) = (coef·k + offset) / n
        if coef == 0.0 {
            let value = offset / n;
            return lo <= value && value <= hi;
        }
        let (ka, kb) = ((lo * n - offset) / coef, (hi * n - offset) / coef);
        k0 = k0.max(ka.min(kb));
        k1 = k1.min(ka.max(kb));
        true
    };
    let inside =
        restrict(-b, -a * c, col as f64, col as f64 + 1.0) && restrict(a, -b * c, row as f64, row as f64 + 1.0);
    if !inside || k1 <= k0 {
        return [DVec2::ZERO; 2];
    }
    let (dk, dk2) = (k1 - k0, 0.5 * (k1 * k1 - k0 * k0));
    let ds_dc = -dk / n;
    let ds_da = -(-b * dk2 - a * c * dk) / (n * n);
    let ds_db = -(a * dk2 - b * c * dk) / (n * n);
    [DVec2::new(ds_db - y1 * ds_dc, -ds_da + x1 * ds_dc), DVec2::new(-ds_db + y0 * ds_dc, ds_da - x0 * ds_dc)]
}

/// `paper_gradient` for a region on either side: `inside_left` (screen y down, the side where
/// `cross(vb − va, p − va) > 0`) is the `α < 0` side of `va → vb`; otherwise reverse the edge.
fn paper_gradient_sided(va: DVec2, vb: DVec2, inside_left: bool, row: i64, col: i64) -> [DVec2; 2] {
    if inside_left {
        paper_gradient(va, vb, row, col)
    } else {
        let [gb, ga] = paper_gradient(vb, va, row, col);
        [ga, gb]
    }
}

fn random_point(rng: &mut Rng, lo: f64, hi: f64) -> DVec2 {
    DVec2::new(rng.range(lo, hi), rng.range(lo, hi))
}

fn close(a: DVec2, b: DVec2, tol: f64) -> bool {
    (a - b).length() <= tol * (1.0 + a.length().max(b.length()))
}

#[test]
fn alpha_negative_side_is_the_left_side() {
    // The sign convention the comparison relies on: α(p) = −cross(v1 − v0, p − v0).
    let mut rng = Rng::new(1);
    for _ in 0..100 {
        let (v0, v1, p) =
            (random_point(&mut rng, -3.0, 3.0), random_point(&mut rng, -3.0, 3.0), random_point(&mut rng, -3.0, 3.0));
        let (a, b, c) = (v1.y - v0.y, v0.x - v1.x, v1.x * v0.y - v0.x * v1.y);
        let alpha = a * p.x + b * p.y + c;
        let cross = (v1 - v0).perp_dot(p - v0);
        assert!((alpha + cross).abs() <= 1e-12 * (1.0 + cross.abs()));
    }
}

#[test]
fn simple_form_equals_paper_form_on_random_segments() {
    let mut rng = Rng::new(2);
    let (mut compared, mut nonzero) = (0, 0);
    for _ in 0..20_000 {
        // Segments around pixel (row, col): crossing it, ending inside it, or missing it.
        let (row, col) = ((rng.range(-3.0, 3.0)).floor() as i64, (rng.range(-3.0, 3.0)).floor() as i64);
        let origin = DVec2::new(col as f64, row as f64);
        let va = origin + random_point(&mut rng, -1.5, 2.5);
        let vb = origin + random_point(&mut rng, -1.5, 2.5);
        let inside_left = rng.uniform() < 0.5;
        let simple = pixel_area_gradient(va, vb, inside_left, row, col);
        let paper = paper_gradient_sided(va, vb, inside_left, row, col);
        for k in 0..2 {
            assert!(
                close(simple[k], paper[k], 1e-9),
                "{va} → {vb} left {inside_left} pixel ({row}, {col}): {simple:?} vs {paper:?}"
            );
        }
        compared += 1;
        nonzero += (simple[0] != DVec2::ZERO) as usize;
    }
    assert!(nonzero > compared / 4, "too few segments cross their pixel: {nonzero} of {compared}");
    // Axis-parallel segments (B = 0 or A = 0) through the pixel.
    for (va, vb) in [
        (DVec2::new(0.3, -0.5), DVec2::new(0.3, 1.7)),
        (DVec2::new(-0.4, 0.6), DVec2::new(0.8, 0.6)),
        (DVec2::new(0.9, 0.2), DVec2::new(0.1, 0.2)),
    ] {
        for inside_left in [true, false] {
            let (s, p) =
                (pixel_area_gradient(va, vb, inside_left, 0, 0), paper_gradient_sided(va, vb, inside_left, 0, 0));
            assert!(close(s[0], p[0], 1e-12) && close(s[1], p[1], 1e-12), "{s:?} vs {p:?}");
            assert!(s[0] != DVec2::ZERO || s[1] != DVec2::ZERO);
        }
    }
}

#[test]
fn degenerate_segments_give_zero() {
    let p = DVec2::new(0.4, 0.3);
    for inside_left in [true, false] {
        // Zero length.
        assert_eq!(pixel_area_gradient(p, p, inside_left, 0, 0), [DVec2::ZERO; 2]);
        assert_eq!(paper_gradient_sided(p, p, inside_left, 0, 0), [DVec2::ZERO; 2]);
        // Missing the pixel.
        let (a, b) = (DVec2::new(2.2, 0.1), DVec2::new(3.0, 0.9));
        assert_eq!(pixel_area_gradient(a, b, inside_left, 0, 0), [DVec2::ZERO; 2]);
        // Touching only a corner.
        let (a, b) = (DVec2::new(1.0, 1.0), DVec2::new(2.0, 0.0));
        let g = pixel_area_gradient(a, b, inside_left, 0, 0);
        assert!(g.iter().all(|v| v.is_finite() && v.length() == 0.0), "{g:?}");
    }
}

#[test]
fn liang_barsky_clip_matches_brute_force() {
    let mut rng = Rng::new(3);
    for _ in 0..2000 {
        let (p0, d) = (rng.range(-2.0, 3.0), rng.range(-3.0, 3.0));
        let (lo, hi) = (0.0, 1.0);
        let mut s = (0.0, 1.0);
        let kept = clip_parameter(p0, d, lo, hi, &mut s);
        // Brute force on a fine grid of t.
        let inside: Vec<f64> =
            (0..=10_000).map(|k| k as f64 / 10_000.0).filter(|&t| (lo..=hi).contains(&(p0 + t * d))).collect();
        if inside.len() >= 2 {
            assert!(kept);
            assert!(
                (s.0 - inside[0]).abs() <= 1e-4 && (s.1 - inside[inside.len() - 1]).abs() <= 1e-4,
                "{p0} {d}: {s:?}"
            );
        } else if inside.is_empty() {
            assert!(!kept || s.1 - s.0 < 1e-4, "{p0} {d}: {s:?}");
        }
    }
    assert_eq!(segment_weights(0.0, 1.0), [0.5, 0.5]);
    assert_eq!(segment_weights(0.25, 0.25), [0.0, 0.0]);
}

/// Whether a triangle is safely away (0.01 px) from the kinks of its pixel-area function (a
/// vertex on a pixel border, an edge through a pixel corner), where central differences are not
/// the derivative, and from tiny features whose curvature inflates their truncation error.
fn generic(t: &[DVec2; 3]) -> bool {
    const M: f64 = 1e-2;
    let corners = [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0), DVec2::new(1.0, 1.0)];
    let near_border = |x: f64| x.abs() < M || (x - 1.0).abs() < M;
    let vertex_ok = t.iter().all(|p| !near_border(p.x) && !near_border(p.y));
    let edge_ok = (0..3).all(|k| {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        let d = b - a;
        corners.iter().all(|&c| {
            let s = ((c - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
            (a + s * d - c).length() > M
        }) && d.length() > M
    });
    vertex_ok && edge_ok && (t[1] - t[0]).perp_dot(t[2] - t[0]).abs() > M
}

#[test]
fn both_forms_match_finite_differences_of_triangle_pixel_area() {
    // Pixel (0, 0) of a 1×1 image; random triangles around it. The analytic derivative of
    // area(triangle ∩ pixel) is the sum over the three edges (interior on the left of v_k → v_k+1
    // when the triangle is counter-clockwise in the cross > 0 sense).
    let mut rng = Rng::new(4);
    let h = 1.0 / 16384.0;
    let (mut checked, mut worst) = (0, 0.0f64);
    while checked < 400 {
        let t = [0, 1, 2].map(|_| {
            let p = random_point(&mut rng, -0.9, 1.9);
            Vec2::new(p.x as f32, p.y as f32).as_dvec2()
        });
        if !generic(&t) {
            continue;
        }
        let area = |v: &[Vec2]| exact_coverage(v, &[[0, 1, 2]], 1, 1)[0];
        let verts: Vec<Vec2> = t.iter().map(|p| p.as_vec2()).collect();
        let a0 = area(&verts);
        if a0 <= 0.0 || a0 >= 1.0 {
            continue; // no edge inside the pixel: nothing to differentiate
        }
        let left = (t[1] - t[0]).perp_dot(t[2] - t[0]) > 0.0;
        let (mut simple, mut paper) = ([DVec2::ZERO; 3], [DVec2::ZERO; 3]);
        for k in 0..3 {
            let (a, b) = (k, (k + 1) % 3);
            let s = pixel_area_gradient(t[a], t[b], left, 0, 0);
            let p = paper_gradient_sided(t[a], t[b], left, 0, 0);
            simple[a] += s[0];
            simple[b] += s[1];
            paper[a] += p[0];
            paper[b] += p[1];
        }
        for v in 0..3 {
            let mut fd = DVec2::ZERO;
            for c in 0..2 {
                let (mut plus, mut minus) = (verts.clone(), verts.clone());
                (plus[v][c], minus[v][c]) = symmetric_pair(verts[v][c], h);
                fd[c] = (area(&plus) - area(&minus)) / (plus[v][c] as f64 - minus[v][c] as f64);
            }
            let err = (simple[v] - fd).length().max((paper[v] - fd).length());
            worst = worst.max(err);
            assert!(err <= 1e-6, "triangle {t:?} vertex {v}: simple {:?} paper {:?} fd {fd:?}", simple[v], paper[v]);
        }
        checked += 1;
    }
    println!("{checked} triangles, worst |analytic − fd| = {worst:.2e}");
}

//! Exact-area coverage: the slow, simple reference the renderer is tested against.
//!
//! [`exact_coverage`] computes, for every pixel, the area of the pixel square covered by the
//! union of a set of 2D triangles, to about `1e-12` absolute, in `f64`. It is the ideal image of
//! ARCHITECTURE.md, *The method* (the F → ∞ limit of the supersampled forward pass), and the
//! function whose derivative the analytic backward returns; tests use it for central finite
//! differences.
//!
//! # Method ("slab method")
//!
//! Per pixel, every triangle that overlaps it is clipped to the pixel square (Sutherland–Hodgman,
//! `f64`), giving convex polygons. Let `xs` be the x-coordinates of all polygon vertices and of
//! all pairwise crossings of edges of different polygons. Between consecutive `xs` no boundary
//! of the union starts, ends or crosses another, so the covered length of a vertical line is
//! linear in x: the length of the union of the polygons' y-intervals at the slab's midpoint,
//! times the slab's width, is the slab's covered area exactly. Shortcuts: a pixel inside one
//! triangle is `1`, a pixel touched by one triangle is its clipped polygon's shoelace area.
//!
//! Triangles are binned by rows, then by the columns their part inside the row spans, and rows
//! run in parallel (rayon). This is not the hot path: it is meant for tests and small images.

use glam::{DVec2, Vec2};
use rayon::prelude::*;

/// Exact covered area of each pixel by the union of 2D triangles.
///
/// Coordinates are in pixel units, y down; pixel `(i, j)` (row `i`, column `j`) is the square
/// `[j, j+1] × [i, i+1]`. Returns `width * height` values in `[0, 1]`, row-major.
///
/// Union semantics: overlapping triangles count once, winding does not matter, zero-area
/// triangles contribute nothing, and triangles partly or wholly outside the image are fine
/// (only their inside part counts). Triangles with a non-finite vertex are skipped.
///
/// # Panics
///
/// Indices are assumed valid: an index `>= vertices.len()` panics.
pub fn exact_coverage(vertices: &[Vec2], triangles: &[[u32; 3]], width: u32, height: u32) -> Vec<f64> {
    let vertices: Vec<DVec2> = vertices.iter().map(|v| v.as_dvec2()).collect();
    exact_coverage_f64(&vertices, triangles, width, height)
}

/// [`exact_coverage`] with `f64` vertex coordinates.
///
/// For finite differences with steps far below `f32` resolution: moving an `f32` vertex by a
/// small step `h` rounds the moved position to `f32` and spoils the difference quotient; in
/// `f64` the step is kept exactly enough that the quotient's error is that of the area itself
/// (about `1e-12 / h`). Same semantics and panics as [`exact_coverage`].
pub fn exact_coverage_f64(vertices: &[DVec2], triangles: &[[u32; 3]], width: u32, height: u32) -> Vec<f64> {
    let (w, h) = (width as usize, height as usize);
    let mut out = vec![0.0; w * h];
    if w == 0 || h == 0 {
        return out;
    }

    // Valid triangles in f64, counter-clockwise in the (x, y) frame (cross > 0).
    let tris: Vec<[DVec2; 3]> = triangles
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.map(|k| vertices[k as usize]);
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                return None;
            }
            let cross = (b - a).perp_dot(c - a);
            if cross > 0.0 {
                Some([a, b, c])
            } else if cross < 0.0 {
                Some([a, c, b])
            } else {
                None
            }
        })
        .collect();

    // Row bins: triangle ids whose bounding box overlaps the row's band.
    let mut rows: Vec<Vec<u32>> = vec![Vec::new(); h];
    for (id, t) in tris.iter().enumerate() {
        let ymin = t[0].y.min(t[1].y).min(t[2].y);
        let ymax = t[0].y.max(t[1].y).max(t[2].y);
        if let Some((r0, r1)) = cell_range(ymin, ymax, h) {
            for row in &mut rows[r0..=r1] {
                row.push(id as u32);
            }
        }
    }

    out.par_chunks_mut(w).enumerate().for_each_init(Scratch::default, |s, (i, out_row)| {
        let y0 = i as f64;
        for bin in &mut s.columns {
            bin.clear();
        }
        s.columns.resize_with(w, Vec::new);
        // Column bins: the x-extent of the triangle's part inside this row's band.
        for &id in &rows[i] {
            let band = Poly::triangle(&tris[id as usize]).clip(1, y0, true).clip(1, y0 + 1.0, false);
            if band.n < 3 {
                continue;
            }
            let v = &band.v[..band.n];
            let xmin = v.iter().fold(f64::INFINITY, |m, p| m.min(p.x));
            let xmax = v.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p.x));
            if let Some((c0, c1)) = cell_range(xmin, xmax, w) {
                for bin in &mut s.columns[c0..=c1] {
                    bin.push(id);
                }
            }
        }
        for (j, px) in out_row.iter_mut().enumerate() {
            let ids = std::mem::take(&mut s.columns[j]);
            let origin = DVec2::new(j as f64, y0);
            *px = pixel_coverage(&tris, &ids, origin, s);
            s.columns[j] = ids;
        }
    });
    out
}

/// `outside + (inside - outside) * coverage` per pixel, with coverage from [`exact_coverage`]
/// (the ideal image of ARCHITECTURE.md, *The method*, with `p1 = inside`, `p0 = outside`).
pub fn exact_image(
    vertices: &[Vec2],
    triangles: &[[u32; 3]],
    width: u32,
    height: u32,
    inside: f32,
    outside: f32,
) -> Vec<f64> {
    let (p1, p0) = (inside as f64, outside as f64);
    let mut img = exact_coverage(vertices, triangles, width, height);
    for v in &mut img {
        *v = p0 + (p1 - p0) * *v;
    }
    img
}

/// Cells `[c0, c1]` (of `n` unit cells starting at 0) that the closed range `[lo, hi]` may
/// overlap with positive measure, with a small conservative margin; `None` when none.
fn cell_range(lo: f64, hi: f64, n: usize) -> Option<(usize, usize)> {
    const MARGIN: f64 = 1e-9;
    let c0 = (lo - MARGIN).floor().max(0.0);
    let c1 = ((hi + MARGIN).ceil() - 1.0).min(n as f64 - 1.0);
    (c0 <= c1).then_some((c0 as usize, c1 as usize))
}

/// Per-thread buffers, reused from pixel to pixel.
#[derive(Default)]
struct Scratch {
    columns: Vec<Vec<u32>>,
    polys: Vec<Clipped>,
    xs: Vec<f64>,
    intervals: Vec<(f64, f64)>,
}

/// A convex polygon with at most 8 vertices (a triangle clipped by 4 half-planes has at most 7).
#[derive(Clone, Copy)]
struct Poly {
    n: usize,
    v: [DVec2; 8],
}

impl Poly {
    fn triangle(t: &[DVec2; 3]) -> Self {
        let mut v = [DVec2::ZERO; 8];
        v[..3].copy_from_slice(t);
        Poly { n: 3, v }
    }

    /// Sutherland–Hodgman against the half-plane `p[axis] >= c` (`keep_ge`) or `p[axis] <= c`.
    /// New vertices lie exactly on the line (`p[axis] == c`).
    fn clip(&self, axis: usize, c: f64, keep_ge: bool) -> Poly {
        let inside = |p: DVec2| if keep_ge { p[axis] >= c } else { p[axis] <= c };
        let mut out = Poly { n: 0, v: [DVec2::ZERO; 8] };
        if self.n == 0 {
            return out;
        }
        for k in 0..self.n {
            let p = self.v[k];
            let q = self.v[(k + 1) % self.n];
            let (pin, qin) = (inside(p), inside(q));
            if pin {
                out.push(p);
            }
            if pin != qin {
                // One side strictly out, so p[axis] != q[axis].
                let t = (c - p[axis]) / (q[axis] - p[axis]);
                let mut x = p + (q - p) * t;
                x[axis] = c;
                out.push(x);
            }
        }
        out
    }

    fn push(&mut self, p: DVec2) {
        if self.n < self.v.len() {
            self.v[self.n] = p;
            self.n += 1;
        }
    }

    fn verts(&self) -> &[DVec2] {
        &self.v[..self.n]
    }

    /// Unsigned shoelace area.
    fn area(&self) -> f64 {
        let v = self.verts();
        let mut s = 0.0;
        for k in 0..v.len() {
            s += v[k].perp_dot(v[(k + 1) % v.len()]);
        }
        0.5 * s.abs()
    }
}

/// A triangle clipped to the unit pixel square, with its bounding box.
#[derive(Clone, Copy)]
struct Clipped {
    poly: Poly,
    min: DVec2,
    max: DVec2,
}

/// Covered area of the unit pixel at `origin` by the union of triangles `ids`.
fn pixel_coverage(tris: &[[DVec2; 3]], ids: &[u32], origin: DVec2, s: &mut Scratch) -> f64 {
    s.polys.clear();
    for &id in ids {
        // Local coordinates: the pixel is [0, 1]².
        let t = tris[id as usize].map(|p| p - origin);
        if contains_unit_square(&t) {
            return 1.0;
        }
        let poly = Poly::triangle(&t).clip(0, 0.0, true).clip(0, 1.0, false).clip(1, 0.0, true).clip(1, 1.0, false);
        if poly.n < 3 || poly.area() == 0.0 {
            continue;
        }
        let v = poly.verts();
        let min = v.iter().fold(DVec2::INFINITY, |m, &p| m.min(p));
        let max = v.iter().fold(DVec2::NEG_INFINITY, |m, &p| m.max(p));
        s.polys.push(Clipped { poly, min, max });
    }
    match s.polys.len() {
        0 => 0.0,
        1 => s.polys[0].poly.area().min(1.0),
        _ => slab_area(s).clamp(0.0, 1.0),
    }
}

/// Whether the counter-clockwise triangle `t` contains the four corners of `[0, 1]²`.
fn contains_unit_square(t: &[DVec2; 3]) -> bool {
    const CORNERS: [DVec2; 4] =
        [DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0)];
    (0..3).all(|k| {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        CORNERS.iter().all(|&c| (b - a).perp_dot(c - a) >= 0.0)
    })
}

/// Area of the union of `s.polys` (all inside `[0, 1]²`) by the slab method.
fn slab_area(s: &mut Scratch) -> f64 {
    let polys = &s.polys;
    let xs = &mut s.xs;
    xs.clear();
    xs.extend([0.0, 1.0]);
    for p in polys {
        xs.extend(p.poly.verts().iter().map(|v| v.x));
    }
    // Crossings of edges of different polygons. Extra breakpoints never hurt (the covered length
    // stays linear on each piece), missing ones do: accept crossings with a generous tolerance.
    const TOL: f64 = 1e-9;
    for (a, pa) in polys.iter().enumerate() {
        for pb in &polys[a + 1..] {
            if pa.max.x < pb.min.x || pb.max.x < pa.min.x || pa.max.y < pb.min.y || pb.max.y < pa.min.y {
                continue;
            }
            let (va, vb) = (pa.poly.verts(), pb.poly.verts());
            for k in 0..va.len() {
                let (p, r) = (va[k], va[(k + 1) % va.len()] - va[k]);
                for l in 0..vb.len() {
                    let (q, sv) = (vb[l], vb[(l + 1) % vb.len()] - vb[l]);
                    let denom = r.perp_dot(sv);
                    if denom == 0.0 {
                        continue; // parallel: no isolated crossing
                    }
                    let qp = q - p;
                    let t = qp.perp_dot(sv) / denom;
                    let u = qp.perp_dot(r) / denom;
                    if (-TOL..=1.0 + TOL).contains(&t) && (-TOL..=1.0 + TOL).contains(&u) {
                        let x = p.x + t * r.x;
                        if x > 0.0 && x < 1.0 {
                            xs.push(x);
                        }
                    }
                }
            }
        }
    }
    xs.sort_unstable_by(f64::total_cmp);
    xs.dedup();

    let mut area = 0.0;
    for k in 0..xs.len() - 1 {
        let (xa, xb) = (xs[k], xs[k + 1]);
        let xm = 0.5 * (xa + xb);
        if !(xm > xa && xm < xb) {
            continue; // adjacent floats: nothing to integrate
        }
        s.intervals.clear();
        for p in polys {
            if p.min.x < xm && xm < p.max.x {
                if let Some(iv) = y_interval(p.poly.verts(), xm) {
                    s.intervals.push(iv);
                }
            }
        }
        area += (xb - xa) * union_length(&mut s.intervals);
    }
    area
}

/// The y-interval of a convex polygon on the vertical line at `x` (strictly inside its x-range).
fn y_interval(v: &[DVec2], x: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..v.len() {
        let (a, b) = (v[k], v[(k + 1) % v.len()]);
        if a.x == b.x || x < a.x.min(b.x) || x > a.x.max(b.x) {
            continue;
        }
        let y = a.y + (x - a.x) / (b.x - a.x) * (b.y - a.y);
        lo = lo.min(y);
        hi = hi.max(y);
    }
    (hi > lo).then_some((lo, hi))
}

/// Total length of the union of intervals (sorts them in place).
fn union_length(iv: &mut [(f64, f64)]) -> f64 {
    if iv.is_empty() {
        return 0.0;
    }
    iv.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let mut total = 0.0;
    let (mut lo, mut hi) = iv[0];
    for &(a, b) in &iv[1..] {
        if a > hi {
            total += hi - lo;
            (lo, hi) = (a, b);
        } else {
            hi = hi.max(b);
        }
    }
    total + (hi - lo)
}

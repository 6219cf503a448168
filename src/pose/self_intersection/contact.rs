//! The exact-style triangle–triangle test: Möller's interval method in `f64` on `f32` input,
//! telling crossing triangles from touching or coplanar ones.

use glam::{DVec3, Vec3};

/// How two triangles meet, from [`triangle_contact`]. Triangles are closed point sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TriangleContact {
    /// No common point.
    Disjoint,
    /// At least one triangle has (numerically) zero area: degenerate triangles never intersect.
    Degenerate,
    /// The triangles share points but do not pass through each other: a vertex or an edge rests on
    /// the other triangle, or two edges meet. Not penetration.
    Touching,
    /// The surfaces pass through each other: each triangle has vertices strictly on both sides of
    /// the other's plane, and they share a segment of positive length. The only contact the
    /// self-intersection penalty counts.
    Crossing,
    /// Both triangles lie in one plane and overlap (even at a single point). Not counted by the
    /// penalty: coplanar contact has no inside.
    Coplanar,
}

impl TriangleContact {
    /// Whether the closed triangles share at least one point (`Touching`, `Crossing` or
    /// `Coplanar`).
    pub fn intersects(self) -> bool {
        matches!(self, TriangleContact::Touching | TriangleContact::Crossing | TriangleContact::Coplanar)
    }
}

/// A triangle is degenerate when `|e₁ × e₂| ≤ DEGENERATE · max|eᵢ|²`: its smallest angle is below
/// about `1e-10` rad (or it has repeated or collinear vertices). Its plane is then meaningless.
const DEGENERATE: f64 = 1e-10;

#[inline]
pub(super) fn dvec(v: Vec3) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

/// The normal `(b−a)×(c−a)` of a triangle, or `None` when it is degenerate.
#[inline]
pub(super) fn plane_normal(t: &[DVec3; 3]) -> Option<DVec3> {
    let e0 = t[1] - t[0];
    let e1 = t[2] - t[0];
    let e2 = t[2] - t[1];
    let n = e0.cross(e1);
    let longest = e0.length_squared().max(e1.length_squared()).max(e2.length_squared());
    let len = n.length();
    if len > DEGENERATE * longest && len.is_finite() {
        Some(n)
    } else {
        None
    }
}

/// Classifies how triangles `a` and `b` meet. Exact for inputs whose coordinate differences and
/// their products are exact in `f64` (e.g. coordinates on a grid of dyadic fractions); otherwise
/// correct up to `f64` rounding, which can only blur configurations within ~1e-16 (relative) of
/// touching.
///
/// Möller's method: the signed distances of each triangle's vertices to the other's plane reject
/// separated pairs; otherwise each triangle meets the line common to both planes in an interval,
/// and the triangles meet iff the intervals do. Coplanar pairs are tested in 2D (edge crossings,
/// then containment). The penalty uses only [`TriangleContact::Crossing`].
pub fn triangle_contact(a: [Vec3; 3], b: [Vec3; 3]) -> TriangleContact {
    let a = a.map(dvec);
    let b = b.map(dvec);
    let (Some(na), Some(nb)) = (plane_normal(&a), plane_normal(&b)) else {
        return TriangleContact::Degenerate;
    };
    contact_f64(&a, na, &b, nb)
}

/// Whether the closed triangles `a` and `b` share a point (see [`triangle_contact`]): `true` for
/// touching, crossing and overlapping coplanar triangles, `false` for disjoint or degenerate ones.
pub fn triangles_intersect(a: [Vec3; 3], b: [Vec3; 3]) -> bool {
    triangle_contact(a, b).intersects()
}

#[inline]
fn signs(d: &[f64; 3]) -> (bool, bool) {
    let pos = d.iter().any(|&x| x > 0.0);
    let neg = d.iter().any(|&x| x < 0.0);
    (pos, neg)
}

pub(super) fn contact_f64(a: &[DVec3; 3], na: DVec3, b: &[DVec3; 3], nb: DVec3) -> TriangleContact {
    // Signed (unnormalised) distances of a's vertices to b's plane, and conversely.
    let da = [(a[0] - b[0]).dot(nb), (a[1] - b[0]).dot(nb), (a[2] - b[0]).dot(nb)];
    let (a_pos, a_neg) = signs(&da);
    if !a_pos && !a_neg {
        return coplanar_contact(a, b, na);
    }
    if !(a_pos && a_neg) && da.iter().all(|&x| x != 0.0) {
        return TriangleContact::Disjoint;
    }
    let db = [(b[0] - a[0]).dot(na), (b[1] - a[0]).dot(na), (b[2] - a[0]).dot(na)];
    let (b_pos, b_neg) = signs(&db);
    if !b_pos && !b_neg {
        return coplanar_contact(a, b, na);
    }
    if !(b_pos && b_neg) && db.iter().all(|&x| x != 0.0) {
        return TriangleContact::Disjoint;
    }
    let dir = na.cross(nb);
    if dir == DVec3::ZERO {
        // Parallel planes with vertices on both sides can only come from rounding.
        return TriangleContact::Disjoint;
    }
    let origin = a[0];
    let (Some((a_lo, a_hi)), Some((b_lo, b_hi))) =
        (line_interval(a, &da, dir, origin), line_interval(b, &db, dir, origin))
    else {
        return TriangleContact::Disjoint;
    };
    let lo = a_lo.max(b_lo);
    let hi = a_hi.min(b_hi);
    if lo > hi {
        TriangleContact::Disjoint
    } else if a_pos && a_neg && b_pos && b_neg && lo < hi {
        TriangleContact::Crossing
    } else {
        TriangleContact::Touching
    }
}

/// The interval, along `dir` (measured from `origin`), of the points of triangle `t` that lie on
/// the other triangle's plane, given the signed distances `d` of `t`'s vertices to that plane.
fn line_interval(t: &[DVec3; 3], d: &[f64; 3], dir: DVec3, origin: DVec3) -> Option<(f64, f64)> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut add = |p: DVec3| {
        let s = (p - origin).dot(dir);
        lo = lo.min(s);
        hi = hi.max(s);
    };
    for i in 0..3 {
        if d[i] == 0.0 {
            add(t[i]);
        }
        let j = (i + 1) % 3;
        if (d[i] > 0.0 && d[j] < 0.0) || (d[i] < 0.0 && d[j] > 0.0) {
            let s = d[i] / (d[i] - d[j]);
            add(t[i] + (t[j] - t[i]) * s);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// Closed-triangle overlap of two coplanar triangles, in the coordinate plane where `n` is largest.
fn coplanar_contact(a: &[DVec3; 3], b: &[DVec3; 3], n: DVec3) -> TriangleContact {
    let an = n.abs();
    let (i, j) = if an.x >= an.y && an.x >= an.z {
        (1, 2)
    } else if an.y >= an.z {
        (2, 0)
    } else {
        (0, 1)
    };
    let p = a.map(|v| [v[i], v[j]]);
    let q = b.map(|v| [v[i], v[j]]);
    let overlap = (0..3).any(|k| (0..3).any(|l| segments_meet(p[k], p[(k + 1) % 3], q[l], q[(l + 1) % 3])))
        || point_in_triangle(p[0], &q)
        || point_in_triangle(q[0], &p);
    if overlap {
        TriangleContact::Coplanar
    } else {
        TriangleContact::Disjoint
    }
}

#[inline]
fn orient2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Closed segments `ab` and `cd` share a point.
fn segments_meet(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let d1 = orient2d(c, d, a);
    let d2 = orient2d(c, d, b);
    let d3 = orient2d(a, b, c);
    let d4 = orient2d(a, b, d);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    let on = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        r[0] >= p[0].min(q[0]) && r[0] <= p[0].max(q[0]) && r[1] >= p[1].min(q[1]) && r[1] <= p[1].max(q[1])
    };
    (d1 == 0.0 && on(c, d, a)) || (d2 == 0.0 && on(c, d, b)) || (d3 == 0.0 && on(a, b, c)) || (d4 == 0.0 && on(a, b, d))
}

/// `p` lies in the closed (non-degenerate) triangle `t`.
fn point_in_triangle(p: [f64; 2], t: &[[f64; 2]; 3]) -> bool {
    let d = [orient2d(t[0], t[1], p), orient2d(t[1], t[2], p), orient2d(t[2], t[0], p)];
    let (pos, neg) = signs(&d);
    !(pos && neg)
}

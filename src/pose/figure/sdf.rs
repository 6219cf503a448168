//! The body's signed distance field: tapered capsules and ellipsoids, one or more per bone,
//! blended by a smooth minimum; its gradient and the projection of a point onto its zero set.

use glam::Vec3;

use super::{CELL, JOINT_COUNT};

/// Primitives farther than this from a point (by bounding box) do not shape the field there.
const CULL: f32 = 0.08;

/// A solid the body is made of.
#[derive(Clone, Copy, Debug)]
pub(super) enum Shape {
    /// Points within a linearly varying radius of a segment (a tapered capsule).
    Cone { a: Vec3, b: Vec3, ra: f32, rb: f32 },
    /// An ellipsoid with orthonormal axes `u`, `v`, `u × v` and these semi-axes.
    Ellipsoid { centre: Vec3, u: Vec3, v: Vec3, radii: Vec3 },
}

impl Shape {
    fn cone(a: Vec3, b: Vec3, ra: f32, rb: f32) -> Shape {
        Shape::Cone { a, b, ra, rb }
    }

    fn ellipsoid(centre: Vec3, radii: Vec3) -> Shape {
        Shape::Ellipsoid { centre, u: Vec3::X, v: Vec3::Y, radii }
    }

    /// Approximate signed distance (exact for capsules, a smooth bound for the rest).
    pub(super) fn distance(&self, p: Vec3) -> f32 {
        match *self {
            Shape::Cone { a, b, ra, rb } => {
                let ab = b - a;
                let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                (p - (a + ab * t)).length() - (ra + (rb - ra) * t)
            }
            Shape::Ellipsoid { centre, u, v, radii } => {
                let d = p - centre;
                let q = Vec3::new(d.dot(u), d.dot(v), d.dot(u.cross(v)));
                let k0 = (q / radii).length();
                let k1 = (q / (radii * radii)).length();
                if k1 > 0.0 {
                    k0 * (k0 - 1.0) / k1
                } else {
                    -radii.min_element()
                }
            }
        }
    }

    /// An axis-aligned box containing the solid.
    pub(super) fn bounds(&self) -> (Vec3, Vec3) {
        match *self {
            Shape::Cone { a, b, ra, rb } => {
                let r = Vec3::splat(ra.max(rb));
                (a.min(b) - r, a.max(b) + r)
            }
            Shape::Ellipsoid { centre, radii, .. } => {
                let r = Vec3::splat(radii.max_element());
                (centre - r, centre + r)
            }
        }
    }
}

/// A solid, the joint whose bone it belongs to, and how smoothly it blends into what came before.
#[derive(Clone, Copy, Debug)]
pub(super) struct Primitive {
    pub(super) shape: Shape,
    pub(super) joint: usize,
    blend: f32,
    /// The shape's bounds grown by [`CULL`]: farther points ignore the primitive.
    lo: Vec3,
    hi: Vec3,
}

/// The solids of the body, in the order they are blended.
pub(super) fn body_primitives(j: &[Vec3; JOINT_COUNT]) -> Vec<Primitive> {
    let mut out = Vec::new();
    let mut add = |joint: usize, blend: f32, shape: Shape| {
        let (lo, hi) = shape.bounds();
        out.push(Primitive { shape, joint, blend, lo: lo - Vec3::splat(CULL), hi: hi + Vec3::splat(CULL) })
    };
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let torso = 0.04;
    add(0, torso, Shape::ellipsoid(v(0.0, 0.93, -0.005), v(0.165, 0.12, 0.105)));
    add(3, torso, Shape::ellipsoid(v(0.0, 1.07, 0.0), v(0.145, 0.13, 0.10)));
    add(6, torso, Shape::ellipsoid(v(0.0, 1.20, 0.005), v(0.155, 0.12, 0.105)));
    add(9, torso, Shape::ellipsoid(v(0.0, 1.32, 0.0), v(0.17, 0.15, 0.11)));
    add(12, 0.03, Shape::cone(v(0.0, 1.40, -0.01), v(0.0, 1.575, 0.0), 0.056, 0.05));
    add(15, 0.03, Shape::ellipsoid(v(0.0, 1.635, 0.015), v(0.078, 0.105, 0.095)));
    let arm = (j[18] - j[16]).normalize();
    let across = Vec3::Z.cross(arm); // in the xy plane, perpendicular to the arm
    for side in [0, 1] {
        let m = if side == 0 { Vec3::ONE } else { v(-1.0, 1.0, 1.0) };
        let s = |k: usize| k + side;
        // Glutes belong to the pelvis; collars carry the top of the shoulders.
        add(0, 0.03, Shape::ellipsoid(m * v(0.07, 0.885, -0.04), v(0.085, 0.095, 0.08)));
        add(s(13), 0.03, Shape::cone(m * v(0.04, 1.41, -0.01), j[s(16)], 0.06, 0.055));
        add(s(16), 0.02, Shape::cone(j[s(16)], j[s(18)], 0.05, 0.04));
        add(s(18), 0.02, Shape::cone(j[s(18)], j[s(20)], 0.04, 0.03));
        let (arm, across) = (m * arm, m * across);
        add(
            s(20),
            0.015,
            Shape::Ellipsoid { centre: j[s(20)] + 0.05 * arm, u: arm, v: across, radii: v(0.06, 0.025, 0.045) },
        );
        add(
            s(22),
            0.015,
            Shape::Ellipsoid { centre: j[s(20)] + 0.12 * arm, u: arm, v: across, radii: v(0.06, 0.02, 0.04) },
        );
        add(s(1), 0.02, Shape::cone(j[s(1)], j[s(4)], 0.08, 0.055));
        add(s(4), 0.02, Shape::cone(j[s(4)], j[s(7)], 0.055, 0.035));
        let calf = j[s(4)] + 0.3 * (j[s(7)] - j[s(4)]) + v(0.0, 0.0, -0.015);
        add(s(4), 0.02, Shape::ellipsoid(calf, v(0.055, 0.11, 0.055)));
        add(s(7), 0.02, Shape::cone(m * v(0.11, 0.04, -0.05), m * v(0.115, 0.03, 0.09), 0.04, 0.033));
        add(s(10), 0.015, Shape::cone(m * v(0.115, 0.028, 0.09), m * v(0.118, 0.025, 0.15), 0.03, 0.026));
    }
    out
}

/// Polynomial smooth minimum: `min(a, b)` rounded over a width `k`.
fn smooth_min(a: f32, b: f32, k: f32) -> f32 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

/// The body's field: the smooth union of the primitives near `p` (those whose grown bounds
/// contain it). Farther primitives are at least [`CULL`] away, more than any blend width, so
/// leaving them out changes nothing near the surface; a point near none of them gets `CULL`.
pub(super) fn body_sdf(primitives: &[Primitive], p: Vec3) -> f32 {
    let mut acc = f32::INFINITY;
    for prim in primitives {
        if p.cmplt(prim.lo).any() || p.cmpgt(prim.hi).any() {
            continue;
        }
        let d = prim.shape.distance(p);
        acc = if acc.is_finite() { smooth_min(acc, d, prim.blend) } else { d };
    }
    acc.min(CULL)
}

/// The field's gradient at `p` (forward differences).
pub(super) fn gradient(sdf: &impl Fn(Vec3) -> f32, p: Vec3) -> Vec3 {
    gradient_from(sdf, p, sdf(p))
}

/// Forward differences from `f = sdf(p)`.
fn gradient_from(sdf: &impl Fn(Vec3) -> f32, p: Vec3, f: f32) -> Vec3 {
    let e = 1e-3;
    Vec3::new(sdf(p + Vec3::X * e) - f, sdf(p + Vec3::Y * e) - f, sdf(p + Vec3::Z * e) - f) / e
}

/// Newton steps along the gradient onto the zero set (two suffice from a point within a few
/// millimetres of it).
pub(super) fn project_to_surface(sdf: &impl Fn(Vec3) -> f32, mut p: Vec3) -> Vec3 {
    for _ in 0..2 {
        let f = sdf(p);
        if f.abs() < 1e-6 {
            break;
        }
        let g = gradient_from(sdf, p, f);
        let g2 = g.length_squared();
        if g2 < 1e-6 {
            break;
        }
        // Never move farther than a cell: the field is only a bound far from the surface.
        p -= (g * (f / g2)).clamp_length_max(CELL);
    }
    p
}

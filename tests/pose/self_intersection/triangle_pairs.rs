//! The exact triangle–triangle test: crossing, touching, coplanar and degenerate pairs, and random
//! pairs against an edge-piercing oracle.

use super::*;

const A: [Vec3; 3] = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];

#[test]
fn crossing_pairs_are_crossing() {
    // A vertical triangle piercing A's interior.
    let b = [v(0.5, 0.25, -1.0), v(0.25, 0.5, 1.0), v(1.25, 1.0, 0.5)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Crossing);
    assert_eq!(triangle_contact(b, A), TriangleContact::Crossing);
    assert!(triangles_intersect(A, b));
    // Crossing through A's edge (the two surfaces interlock like chain links).
    let b = [v(1.0, -0.5, -0.5), v(1.0, 0.5, -0.5), v(1.0, 0.0, 1.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Crossing);
    // The same planes, but B moved beyond A's hypotenuse: the line meets both, the intervals do not.
    let b = [v(1.5, 1.0, -0.5), v(1.5, 1.5, -0.5), v(1.5, 1.25, 1.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Disjoint);
    assert!(!triangles_intersect(A, b));
    // Planes cross, but B lies entirely above A's plane.
    let b = [v(0.5, 0.5, 0.25), v(0.5, 0.5, 1.0), v(1.0, 0.5, 1.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Disjoint);
}

#[test]
fn touching_is_not_crossing() {
    // A vertex of B resting on A's interior.
    let b = [v(0.5, 0.5, 0.0), v(0.5, 0.5, 1.0), v(1.5, 1.0, 1.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Touching);
    assert_eq!(triangle_contact(b, A), TriangleContact::Touching);
    assert!(triangles_intersect(A, b));
    // An edge of B lying in A's interior, B above.
    let b = [v(0.25, 0.25, 0.0), v(1.0, 0.5, 0.0), v(0.5, 0.5, 1.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Touching);
    // Vertex on vertex (different indices, same place).
    let b = [v(2.0, 0.0, 0.0), v(3.0, 0.0, 1.0), v(3.0, 1.0, 1.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Touching);
    // A vertex of B on A's edge.
    let b = [v(1.0, 1.0, 0.0), v(2.0, 2.0, 0.0), v(1.5, 1.5, 1.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Touching);
    // B straddles A's plane, but A only rests its edge on B: they share a segment, no crossing.
    let b = [v(1.0, -1.0, 1.0), v(1.0, 1.0, -1.0), v(3.0, 0.0, 0.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Touching);
    assert_eq!(triangle_contact(b, A), TriangleContact::Touching);
    // Just apart: the same B lifted a little does not touch.
    let b = [v(0.5, 0.5, 0.001), v(0.5, 0.5, 1.0), v(1.5, 1.0, 1.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Disjoint);
}

#[test]
fn parallel_and_coplanar() {
    // Parallel planes, separated.
    let b = A.map(|p| p + v(0.0, 0.0, 1.0));
    assert_eq!(triangle_contact(A, b), TriangleContact::Disjoint);
    let b = A.map(|p| p + v(0.0, 0.0, -1e-6));
    assert_eq!(triangle_contact(A, b), TriangleContact::Disjoint);
    // Coplanar and overlapping (edges crossing): reported, not counted as crossing.
    let b = A.map(|p| p + v(0.5, 0.5, 0.0));
    assert_eq!(triangle_contact(A, b), TriangleContact::Coplanar);
    assert!(triangles_intersect(A, b));
    // Coplanar, one inside the other (no edge crossing).
    let b = [v(0.25, 0.25, 0.0), v(0.75, 0.25, 0.0), v(0.25, 0.75, 0.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Coplanar);
    assert_eq!(triangle_contact(b, A), TriangleContact::Coplanar);
    // Coplanar, touching at a vertex.
    let b = [v(2.0, 0.0, 0.0), v(3.0, 0.0, 0.0), v(3.0, 1.0, 0.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Coplanar);
    // Coplanar, apart.
    let b = A.map(|p| p + v(3.0, 0.0, 0.0));
    assert_eq!(triangle_contact(A, b), TriangleContact::Disjoint);
    assert!(!triangles_intersect(A, b));
    // Coplanar in a tilted plane.
    let tilt = |p: Vec3| v(p.x, p.y, 0.5 * p.x + 0.25 * p.y);
    assert_eq!(triangle_contact(A.map(tilt), A.map(|p| tilt(p + v(0.5, 0.5, 0.0)))), TriangleContact::Coplanar);
}

#[test]
fn degenerate_triangles_never_intersect() {
    // A needle of collinear points through A's interior.
    let needle = [v(0.5, 0.5, -1.0), v(0.5, 0.5, 1.0), v(0.5, 0.5, 0.25)];
    assert_eq!(triangle_contact(A, needle), TriangleContact::Degenerate);
    assert_eq!(triangle_contact(needle, A), TriangleContact::Degenerate);
    assert!(!triangles_intersect(A, needle));
    // Repeated vertex.
    let b = [v(0.5, 0.5, -1.0), v(0.5, 0.5, -1.0), v(0.5, 0.5, 1.0)];
    assert_eq!(triangle_contact(A, b), TriangleContact::Degenerate);
    // A point.
    assert_eq!(triangle_contact(A, [v(0.5, 0.5, 0.0); 3]), TriangleContact::Degenerate);
    // Both degenerate and coincident.
    assert_eq!(triangle_contact(needle, needle), TriangleContact::Degenerate);
    // Huge and tiny coordinates stay finite and sensible.
    let big = A.map(|p| p * 1e30);
    let b = [v(0.5, 0.25, -1.0), v(0.25, 0.5, 1.0), v(1.25, 1.0, 0.5)].map(|p| p * 1e30);
    assert_eq!(triangle_contact(big, b), TriangleContact::Crossing);
    let small = A.map(|p| p * 1e-30);
    let b = [v(0.5, 0.25, -1.0), v(0.25, 0.5, 1.0), v(1.25, 1.0, 0.5)].map(|p| p * 1e-30);
    assert_eq!(triangle_contact(small, b), TriangleContact::Crossing);
}

/// Independent oracle for generic (non-coplanar, non-touching) pairs: two triangles intersect iff
/// an edge of one pierces the other.
fn edge_pierces(p: Vec3, q: Vec3, t: [Vec3; 3]) -> bool {
    let d = |v: Vec3| glam::DVec3::new(v.x as f64, v.y as f64, v.z as f64);
    let orient = |a: glam::DVec3, b: glam::DVec3, c: glam::DVec3, x: glam::DVec3| (b - a).cross(c - a).dot(x - a);
    let (p, q, a, b, c) = (d(p), d(q), d(t[0]), d(t[1]), d(t[2]));
    let sp = orient(a, b, c, p);
    let sq = orient(a, b, c, q);
    if sp * sq >= 0.0 {
        return false;
    }
    let s1 = orient(p, q, a, b);
    let s2 = orient(p, q, b, c);
    let s3 = orient(p, q, c, a);
    (s1 > 0.0 && s2 > 0.0 && s3 > 0.0) || (s1 < 0.0 && s2 < 0.0 && s3 < 0.0)
}

#[test]
fn random_pairs_agree_with_edge_piercing_oracle() {
    let mut rng = Rng::from_state(0x9e37_79b9_7f4a_7c15);
    let (mut crossing, mut disjoint) = (0, 0);
    for _ in 0..20_000 {
        let a = [random_point(&mut rng), random_point(&mut rng), random_point(&mut rng)];
        let b = [random_point(&mut rng) * 0.8, random_point(&mut rng) * 0.8, random_point(&mut rng) * 0.8];
        let oracle = (0..3).any(|k| edge_pierces(a[k], a[(k + 1) % 3], b) || edge_pierces(b[k], b[(k + 1) % 3], a));
        let got = triangle_contact(a, b);
        match got {
            TriangleContact::Crossing => crossing += 1,
            TriangleContact::Disjoint => disjoint += 1,
            other => panic!("random pair classified {other:?}: {a:?} {b:?}"),
        }
        assert_eq!(got == TriangleContact::Crossing, oracle, "{a:?} {b:?}");
        assert_eq!(triangle_contact(b, a), got, "not symmetric: {a:?} {b:?}");
        // Invariance under vertex order.
        assert_eq!(triangle_contact([a[1], a[2], a[0]], [b[2], b[1], b[0]]), got);
    }
    assert!(crossing > 2000 && disjoint > 2000, "{crossing} crossing, {disjoint} disjoint");
}

#[test]
fn pairs_sharing_a_vertex_are_ignored_by_the_penalty() {
    // Two triangles that cross each other and share vertex 0 (a fold within one vertex's ring).
    let positions = vec![v(0.0, 0.0, 0.0), v(2.0, 0.0, 0.0), v(0.0, 2.0, 0.0), v(1.0, 1.0, 1.0), v(1.0, 1.0, -1.0)];
    let a = [positions[0], positions[1], positions[2]];
    let b = [positions[0], positions[3], positions[4]];
    assert_eq!(triangle_contact(a, b), TriangleContact::Crossing);
    let shared = self_intersection(&positions, &[[0, 1, 2], [0, 3, 4]]).unwrap();
    assert_eq!(shared.intersecting_pairs, 0);
    assert_eq!(shared.surrogate, 0.0);
    // The same geometry with the shared corner duplicated: now it counts.
    let mut split = positions.clone();
    split.push(positions[0]);
    let apart = self_intersection(&split, &[[0, 1, 2], [5, 3, 4]]).unwrap();
    assert_eq!(apart.intersecting_pairs, 1);
    assert!(apart.surrogate > 0.0);
}

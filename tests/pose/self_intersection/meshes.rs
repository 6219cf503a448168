//! The penalty on meshes: inside vertices against a winding-number oracle, descent, the surrogate's
//! gradient, refits, bad input.

use super::*;

/// Several closed parts as one mesh: (positions, triangles, first vertex of each part).
fn assemble(parts: &[(Vec<Vec3>, Vec<[u32; 3]>)]) -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<usize>) {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut starts = Vec::new();
    for (p, t) in parts {
        let offset = positions.len() as u32;
        starts.push(positions.len());
        positions.extend_from_slice(p);
        triangles.extend(t.iter().map(|tri| tri.map(|i| i + offset)));
    }
    (positions, triangles, starts)
}

fn ellipsoid(subdivisions: u32, radii: Vec3, centre: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let s = diffsil::shapes::icosphere(subdivisions);
    (s.positions().iter().map(|p| *p * radii + centre).collect(), s.triangles().to_vec())
}

const TORSO_RADII: Vec3 = Vec3::new(0.35, 0.5, 0.3);
const ARM_RADII: Vec3 = Vec3::new(0.3, 0.07, 0.075);

/// A torso (ellipsoid) and an arm (thin elongated ellipsoid along x) as one mesh, the arm's centre
/// at `arm_x` (the torso's surface is at x = 0.35).
fn torso_and_arm(arm_x: f32) -> (Vec<Vec3>, Vec<[u32; 3]>, usize) {
    let torso = ellipsoid(3, TORSO_RADII, Vec3::ZERO);
    let arm = ellipsoid(3, ARM_RADII, v(arm_x, 0.013, -0.021));
    let (p, t, starts) = assemble(&[torso, arm]);
    (p, t, starts[1])
}

/// Generalised winding number of the closed triangle set `tris` at `x` (solid angles, brute force).
fn winding_number(positions: &[Vec3], tris: &[[u32; 3]], x: Vec3) -> f64 {
    let d = |v: Vec3| glam::DVec3::new(v.x as f64, v.y as f64, v.z as f64);
    let x = d(x);
    let mut total = 0.0;
    for t in tris {
        let [a, b, c] = t.map(|i| d(positions[i as usize]) - x);
        if a == glam::DVec3::ZERO || b == glam::DVec3::ZERO || c == glam::DVec3::ZERO {
            continue; // x is a vertex of this triangle
        }
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        total += 2.0 * num.atan2(den);
    }
    total / (4.0 * std::f64::consts::PI)
}

#[test]
fn closed_sphere_has_no_self_intersection() {
    let sphere = diffsil::shapes::icosphere(3);
    let r = self_intersection(sphere.positions(), sphere.triangles()).unwrap();
    assert_eq!(r.penalty, 0.0);
    assert_eq!(r.surrogate, 0.0);
    assert_eq!(r.intersecting_pairs, 0);
    assert!(r.inside_vertices.is_empty());
    assert_eq!(r.grad.len(), sphere.positions().len());
    assert!(r.grad.iter().all(|g| *g == Vec3::ZERO));
    // Through the checker, with a topology, twice (the second call refits the BVH).
    let mut checker = SelfIntersectionChecker::new(sphere.topology());
    for _ in 0..2 {
        assert_eq!(checker.check(sphere.positions()).unwrap(), r);
    }
    // A bumpy, non-convex closed mesh.
    let blob = diffsil::shapes::blob(40, 64);
    let r = self_intersection(blob.positions(), blob.triangles()).unwrap();
    assert_eq!((r.penalty, r.intersecting_pairs), (0.0, 0));
}

#[test]
fn separated_parts_have_no_penalty() {
    let (positions, triangles, _) = torso_and_arm(0.8);
    let r = self_intersection(&positions, &triangles).unwrap();
    assert_eq!(r.penalty, 0.0);
    assert_eq!(r.surrogate, 0.0);
    assert_eq!(r.intersecting_pairs, 0);
    assert!(r.inside_vertices.is_empty());
    assert!(r.grad.iter().all(|g| *g == Vec3::ZERO));
}

/// The inside vertices are exactly the arm's vertices inside the torso and the torso's vertices
/// inside the arm, by a brute-force winding-number oracle over the other part.
#[test]
fn arm_in_torso_inside_vertices_match_winding_oracle() {
    for arm_x in [0.5f32, 0.45, 0.3, 0.1] {
        let (positions, triangles, arm_start) = torso_and_arm(arm_x);
        let arm_tri_start = triangles.iter().position(|t| t[0] as usize >= arm_start).unwrap();
        let (torso_tris, arm_tris) = triangles.split_at(arm_tri_start);
        let expected: Vec<u32> = (0..positions.len())
            .filter(|&i| {
                let other = if i < arm_start { arm_tris } else { torso_tris };
                winding_number(&positions, other, positions[i]) > 0.5
            })
            .map(|i| i as u32)
            .collect();
        let r = self_intersection(&positions, &triangles).unwrap();
        assert!(r.intersecting_pairs > 0, "arm at {arm_x}");
        assert!(expected.iter().any(|&i| i as usize >= arm_start), "arm at {arm_x}: the arm should reach in");
        assert_eq!(r.inside_vertices, expected, "arm at {arm_x}");
        assert_eq!(r.penalty, expected.len() as f64 / positions.len() as f64);
        assert!(r.surrogate > 0.0);
        assert!(r.grad.iter().all(|g| g.is_finite()));
        // Either winding gives the same answer.
        let flipped: Vec<[u32; 3]> = triangles.iter().map(|t| [t[0], t[2], t[1]]).collect();
        let f = self_intersection(&positions, &flipped).unwrap();
        assert_eq!(f.inside_vertices, r.inside_vertices);
        assert!((f.surrogate - r.surrogate).abs() <= 1e-12 * r.surrogate);
    }
}

/// An arm swallowed whole (no crossing triangle) still counts: its vertices are inside.
#[test]
fn buried_part_counts_without_crossings() {
    let torso = ellipsoid(2, TORSO_RADII, Vec3::ZERO);
    let pebble = ellipsoid(1, Vec3::splat(0.05), v(0.1, 0.05, 0.0));
    let (positions, triangles, starts) = assemble(&[torso, pebble]);
    let r = self_intersection(&positions, &triangles).unwrap();
    assert_eq!(r.intersecting_pairs, 0);
    let expected: Vec<u32> = (starts[1] as u32..positions.len() as u32).collect();
    assert_eq!(r.inside_vertices, expected);
    assert_eq!(r.surrogate, 0.0);
}

fn translate_part(positions: &mut [Vec3], range: std::ops::Range<usize>, by: Vec3) {
    for p in &mut positions[range] {
        *p += by;
    }
}

/// Gradient descent on the parts' translations (the chain rule: a part's translation gradient is
/// the sum of its vertices' gradients) pushes the arm out of the torso. The surrogate measures the
/// depth next to the intersection curve, so as the arm slides out it saw-tooths (pairs appear at
/// the moving curve); the penalty falls steadily to zero.
#[test]
fn descent_on_part_translations_separates_them() {
    let (mut positions, triangles, arm_start) = torso_and_arm(0.45);
    let n = positions.len();
    let mut checker = SelfIntersectionChecker::from_triangles(n, &triangles).unwrap();
    let first = checker.check(&positions).unwrap();
    assert!(first.penalty > 0.1, "{}", first.penalty);
    let mut previous = first.clone();
    let (mut steps, mut penalty_decreased) = (0, 0);
    let step = 0.004 * n as f32;
    while previous.penalty > 0.0 && steps < 300 {
        let g_torso: Vec3 = previous.grad[..arm_start].iter().sum();
        let g_arm: Vec3 = previous.grad[arm_start..].iter().sum();
        // Translation invariance of the surrogate.
        assert!((g_arm + g_torso).length() <= 1e-4 * g_arm.length(), "{g_arm} {g_torso}");
        // The push is outward: the arm (on the torso's +x side) goes +x, the torso −x.
        assert!(g_arm.x < 0.0 && -g_arm.x > 2.0 * g_arm.y.abs().max(g_arm.z.abs()), "step {steps}: {g_arm}");
        translate_part(&mut positions, 0..arm_start, -step * g_torso);
        translate_part(&mut positions, arm_start..n, -step * g_arm);
        let next = checker.check(&positions).unwrap();
        if next.penalty < previous.penalty {
            penalty_decreased += 1;
        }
        previous = next;
        steps += 1;
    }
    assert_eq!(previous.penalty, 0.0, "still intersecting after {steps} steps");
    assert_eq!((previous.intersecting_pairs, previous.surrogate), (0, 0.0));
    assert!(steps >= 10, "separated in {steps} steps: the step is too large for this test to mean much");
    assert!(penalty_decreased * 10 >= steps * 7, "penalty decreased in only {penalty_decreased} of {steps} steps");
}

/// Per-vertex gradient descent on a shallow penetration removes it (the step must be small: the
/// surrogate's curvature grows with the number of crossing pairs that share a vertex).
#[test]
fn per_vertex_descent_removes_a_shallow_penetration() {
    let (mut positions, triangles, _) = torso_and_arm(0.62);
    let n = positions.len();
    let mut checker = SelfIntersectionChecker::from_triangles(n, &triangles).unwrap();
    let first = checker.check(&positions).unwrap();
    assert!(first.penalty > 0.0 && first.surrogate > 0.0);
    let mut current = first.clone();
    let step = 0.01 * n as f32;
    for k in 0..30 {
        for (p, g) in positions.iter_mut().zip(&current.grad) {
            *p -= step * *g;
        }
        let next = checker.check(&positions).unwrap();
        if k == 0 {
            assert!(next.surrogate < current.surrogate, "{} -> {}", current.surrogate, next.surrogate);
        }
        current = next;
        if current.penalty == 0.0 && current.surrogate == 0.0 {
            break;
        }
    }
    assert_eq!((current.penalty, current.surrogate, current.intersecting_pairs), (0.0, 0.0, 0));
}

fn surrogate_at(checker: &mut SelfIntersectionChecker, positions: &[Vec3]) -> (SelfIntersection, Vec<[u32; 2]>) {
    let r = checker.check(positions).unwrap();
    (r, checker.crossing_pairs().to_vec())
}

#[test]
fn surrogate_gradient_matches_central_differences() {
    let (positions, triangles, _) = torso_and_arm(0.45);
    let n = positions.len();
    let mut checker = SelfIntersectionChecker::from_triangles(n, &triangles).unwrap();
    let (r, pairs) = surrogate_at(&mut checker, &positions);
    assert!(r.surrogate > 0.0);
    // Only vertices with a nonzero gradient matter; perturb everything anyway.
    let mut rng = Rng::from_state(12345);
    // Small enough that the crossing pairs rarely change; the f32 rounding of the perturbed
    // positions is accounted for exactly (the analytic side uses the perturbation as rounded).
    let h = 1e-5f32;
    let mut checked = 0;
    for _ in 0..10 {
        let dir: Vec<Vec3> = (0..n).map(|_| random_point(&mut rng)).collect();
        let plus: Vec<Vec3> = positions.iter().zip(&dir).map(|(p, d)| *p + h * *d).collect();
        let minus: Vec<Vec3> = positions.iter().zip(&dir).map(|(p, d)| *p - h * *d).collect();
        let (rp, pp) = surrogate_at(&mut checker, &plus);
        let (rm, pm) = surrogate_at(&mut checker, &minus);
        if pp != pairs || pm != pairs {
            continue; // a crossing pair appeared or vanished: the surrogate jumps there
        }
        let analytic: f64 =
            r.grad.iter().zip(plus.iter().zip(&minus)).map(|(g, (p, m))| g.as_dvec3().dot((*p - *m).as_dvec3())).sum();
        let numeric = rp.surrogate - rm.surrogate;
        let err = (analytic - numeric).abs() / analytic.abs().max(numeric.abs());
        assert!(err <= 1e-3, "analytic {analytic:e}, numeric {numeric:e}, relative error {err:e}");
        checked += 1;
    }
    assert!(checked >= 7, "only {checked} of 10 directions kept the crossing pairs");
    // And one vertex at a time along each axis, for the vertices with the largest gradients.
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| r.grad[b].length().total_cmp(&r.grad[a].length()));
    let mut single = 0;
    for &i in &order[..6] {
        for axis in 0..3 {
            let mut plus = positions.clone();
            let mut minus = positions.clone();
            plus[i][axis] += h;
            minus[i][axis] -= h;
            let (rp, pp) = surrogate_at(&mut checker, &plus);
            let (rm, pm) = surrogate_at(&mut checker, &minus);
            if pp != pairs || pm != pairs {
                continue;
            }
            single += 1;
            let numeric = (rp.surrogate - rm.surrogate) / (plus[i][axis] - minus[i][axis]) as f64;
            let analytic = r.grad[i][axis] as f64;
            let scale = r.grad[i].length() as f64;
            assert!(
                (analytic - numeric).abs() <= 1e-3 * scale,
                "vertex {i} axis {axis}: analytic {analytic:e}, numeric {numeric:e}"
            );
        }
    }
    assert!(single >= 14, "only {single} of 18 single-coordinate perturbations kept the crossing pairs");
}

/// Refitting the BVH and rebuilding it every call give the same results over a motion.
#[test]
fn refit_and_rebuild_agree() {
    let (_, triangles, _) = torso_and_arm(0.0);
    let (p0, _, _) = torso_and_arm(0.0);
    let mut refit = SelfIntersectionChecker::from_triangles(p0.len(), &triangles).unwrap();
    let mut rebuild = SelfIntersectionChecker::from_triangles(p0.len(), &triangles).unwrap();
    rebuild.set_rebuild_policy(RebuildPolicy::Always);
    // Tight refit threshold so that this motion also exercises the rebuild-on-degradation path.
    refit.set_rebuild_policy(RebuildPolicy::Refit { factor: 1.05 });
    for k in 0..12 {
        let (positions, _, _) = torso_and_arm(0.9 - 0.08 * k as f32);
        let a = refit.check(&positions).unwrap();
        let b = rebuild.check(&positions).unwrap();
        assert_eq!(a, b, "arm at step {k}");
        assert_eq!(refit.crossing_pairs(), rebuild.crossing_pairs());
    }
    assert_eq!(rebuild.rebuild_count(), 12);
    assert!(refit.rebuild_count() > 1 && refit.rebuild_count() < 12, "{} rebuilds", refit.rebuild_count());
}

#[test]
fn bad_input_is_an_error() {
    let sphere = diffsil::shapes::icosphere(1);
    let mut positions = sphere.positions().to_vec();
    positions[7].y = f32::NAN;
    match self_intersection(&positions, sphere.triangles()) {
        Err(Error::NonFiniteVertex { vertex: 7, .. }) => {}
        other => panic!("expected NonFiniteVertex, got {other:?}"),
    }
    positions[7].y = f32::INFINITY;
    assert!(matches!(self_intersection(&positions, sphere.triangles()), Err(Error::NonFiniteVertex { vertex: 7, .. })));
    let mut triangles = sphere.triangles().to_vec();
    triangles[3][1] = 1000;
    match self_intersection(sphere.positions(), &triangles) {
        Err(Error::IndexOutOfRange { triangle: 3, index: 1000, .. }) => {}
        other => panic!("expected IndexOutOfRange, got {other:?}"),
    }
    let mut checker = SelfIntersectionChecker::new(sphere.topology());
    assert!(matches!(checker.check(&positions[..5]), Err(Error::LengthMismatch { .. })));
    // The checker still works after errors.
    assert_eq!(checker.check(sphere.positions()).unwrap().penalty, 0.0);
}

#[test]
fn empty_and_degenerate_meshes_have_zero_penalty() {
    let r = self_intersection(&[], &[]).unwrap();
    assert_eq!((r.penalty, r.surrogate, r.intersecting_pairs), (0.0, 0.0, 0));
    assert!(r.inside_vertices.is_empty() && r.grad.is_empty());
    // Vertices but no triangles.
    let r = self_intersection(&[v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0)], &[]).unwrap();
    assert_eq!(r.penalty, 0.0);
    assert_eq!(r.grad, vec![Vec3::ZERO; 2]);
    // One triangle.
    let r = self_intersection(&[v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)], &[[0, 1, 2]]).unwrap();
    assert_eq!((r.penalty, r.surrogate, r.intersecting_pairs), (0.0, 0.0, 0));
    // Extreme but finite coordinates: no panic, no NaN, the same answers as at unit scale.
    let (positions, triangles, _) = torso_and_arm(0.45);
    let unit = self_intersection(&positions, &triangles).unwrap();
    for scale in [1e-30f32, 1e30, 3e38 / 1.3] {
        let scaled: Vec<Vec3> = positions.iter().map(|p| *p * scale).collect();
        let r = self_intersection(&scaled, &triangles).unwrap();
        assert!(r.surrogate.is_finite() && r.grad.iter().all(|g| g.is_finite()), "scale {scale}");
        assert_eq!(r.inside_vertices, unit.inside_vertices, "scale {scale}");
        assert_eq!(r.intersecting_pairs, unit.intersecting_pairs, "scale {scale}");
    }
    // All vertices at one point: every triangle is degenerate.
    let sphere = diffsil::shapes::icosphere(1);
    let collapsed = vec![v(0.5, 0.5, 0.5); sphere.positions().len()];
    let r = self_intersection(&collapsed, sphere.triangles()).unwrap();
    assert_eq!((r.penalty, r.surrogate, r.intersecting_pairs), (0.0, 0.0, 0));
    assert!(r.grad.iter().all(|g| *g == Vec3::ZERO));
    // Flattened onto a plane: many coplanar overlaps, no crossing, nothing inside, no NaN.
    let flat: Vec<Vec3> = sphere.positions().iter().map(|p| v(p.x, p.y, 0.0)).collect();
    let r = self_intersection(&flat, sphere.triangles()).unwrap();
    assert!(r.penalty.is_finite() && r.surrogate.is_finite());
    assert!(r.grad.iter().all(|g| g.is_finite()));
}

/// The built-in figure with its left elbow bent so that the forearm folds into the torso: the
/// penalty is positive, the inside vertices are forearm and torso vertices, and gradient descent on
/// the pose (the surrogate's gradient through the skinning backward) unfolds the elbow.
#[test]
fn figure_elbow_folded_into_torso() {
    use diffsil::pose::figure::builtin_figure;
    use diffsil::pose::skin::Pose;
    let figure = builtin_figure();
    let names = &figure.skeleton.names;
    let joint = |name: &str| names.iter().position(|n| n == name).unwrap();
    let (elbow, wrist, hand) = (joint("left_elbow"), joint("left_wrist"), joint("left_hand"));
    let mut checker = SelfIntersectionChecker::new(figure.mesh.topology());

    let rest = Pose::rest(figure.joint_count());
    let r = checker.check(&figure.skin(&rest).unwrap()).unwrap();
    assert_eq!((r.penalty, r.intersecting_pairs), (0.0, 0), "the rest pose intersects itself");

    // The A-pose forearm points down and out (+x); turning it about z by −2.2 rad swings it
    // across the chest.
    let mut pose = rest.clone();
    pose.joint_rotations[elbow] = Vec3::new(0.0, 0.0, -2.2);
    let positions = figure.skin(&pose).unwrap();
    let first = checker.check(&positions).unwrap();
    assert!(first.penalty > 0.005, "penalty {}", first.penalty);
    assert!(first.intersecting_pairs > 0);
    // Inside vertices: forearm/hand vertices (mostly bound to the elbow and below) and torso ones.
    let on_forearm = |i: u32| {
        let (js, ws) = (figure.joints[i as usize], figure.weights[i as usize]);
        (0..4).map(|k| if [elbow, wrist, hand].contains(&(js[k] as usize)) { ws[k] } else { 0.0 }).sum::<f32>() > 0.5
    };
    let forearm_inside = first.inside_vertices.iter().filter(|&&i| on_forearm(i)).count();
    let other_inside = first.inside_vertices.len() - forearm_inside;
    assert!(
        forearm_inside > 0 && other_inside > 0,
        "{forearm_inside} forearm and {other_inside} other vertices inside"
    );
    // The inside set is what the winding number says: at a vertex of a closed mesh, its own
    // surface contributes ½ (its incident triangles contribute 0), each enclosing part 1 more.
    let tris = figure.mesh.triangles();
    let expected: Vec<u32> = (0..positions.len() as u32)
        .filter(|&i| winding_number(&positions, tris, positions[i as usize]) > 1.0)
        .collect();
    assert_eq!(first.inside_vertices, expected);
    // Every inside forearm vertex lies on the torso's side of the elbow (it swung in, towards −x).
    let elbow_x = figure.joint_transforms(&pose).unwrap()[elbow].w_axis.x;
    assert!(first.inside_vertices.iter().filter(|&&i| on_forearm(i)).all(|&i| positions[i as usize].x < elbow_x));

    // Descent on the elbow rotation alone, normalised steps of 0.05 rad.
    let mut current = first.clone();
    let mut steps = 0;
    while current.penalty > 0.0 && steps < 60 {
        let (_, cache) = figure.skin_with_cache(&pose).unwrap();
        let g = figure.backward(&cache, &current.grad).unwrap().joint_rotations[elbow];
        // Unfolding turns the elbow back towards 0 about z.
        assert!(g.z < 0.0, "step {steps}: elbow gradient {g}");
        pose.joint_rotations[elbow] -= 0.05 * g / g.length();
        current = checker.check(&figure.skin(&pose).unwrap()).unwrap();
        steps += 1;
    }
    eprintln!(
        "figure: {} vertices; elbow at -2.2 rad: penalty {:.4} ({forearm_inside} forearm + {other_inside} other \
         vertices inside, {} crossing pairs); unfolded to {:.3} rad in {steps} steps",
        positions.len(),
        first.penalty,
        first.intersecting_pairs,
        pose.joint_rotations[elbow].z
    );
    assert_eq!(current.penalty, 0.0, "still intersecting after {steps} steps");
    assert!(steps >= 3, "{steps} steps");
    assert!(pose.joint_rotations[elbow].z > -2.2);
}

/// The crossing pairs equal a brute-force scan of every pair of triangles (those sharing a
/// vertex left out) on the built-in figure, one checker refitted along a sequence of poses: the
/// elbow folded into the torso, then random poses with joint rotations up to 1.6 times the
/// random poses' limits. The BVH's leaves hold up to eight triangles, tested four at a time, so
/// this covers full and partial groups of lanes on a real mesh.
#[test]
fn crossing_pairs_match_brute_force_on_posed_figures() {
    use diffsil::pose::figure::{builtin_figure, random_pose_limits};
    use diffsil::pose::fit::random_pose;
    use diffsil::pose::skin::Pose;
    let figure = builtin_figure();
    let tris = figure.mesh.triangles();
    let elbow = figure.skeleton.names.iter().position(|n| n == "left_elbow").unwrap();
    let mut folded = Pose::rest(figure.joint_count());
    folded.joint_rotations[elbow] = Vec3::new(0.0, 0.0, -2.2);
    // Limits 1.6 times the random poses' own: limbs swing through the body.
    let limits: Vec<f32> = random_pose_limits(&figure.skeleton).iter().map(|l| 1.6 * l).collect();
    let poses = std::iter::once(folded).chain((1..=4).map(|seed| random_pose(&limits, 1.0, seed)));
    let mut checker = SelfIntersectionChecker::new(figure.mesh.topology());
    let mut crossings = 0;
    for (k, pose) in poses.enumerate() {
        let positions = figure.skin(&pose).unwrap();
        checker.check(&positions).unwrap();
        // Two triangles can only cross where their boxes meet.
        let boxes: Vec<(Vec3, Vec3)> = tris
            .iter()
            .map(|t| {
                let p = t.map(|i| positions[i as usize]);
                (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]))
            })
            .collect();
        let mut expected = Vec::new();
        for i in 0..tris.len() {
            for j in i + 1..tris.len() {
                let ((lo_i, hi_i), (lo_j, hi_j)) = (boxes[i], boxes[j]);
                if lo_i.cmpgt(hi_j).any() || lo_j.cmpgt(hi_i).any() || tris[i].iter().any(|v| tris[j].contains(v)) {
                    continue;
                }
                let (a, b) = (tris[i].map(|v| positions[v as usize]), tris[j].map(|v| positions[v as usize]));
                if triangle_contact(a, b) == TriangleContact::Crossing {
                    expected.push([i as u32, j as u32]);
                }
            }
        }
        assert_eq!(checker.crossing_pairs(), &expected[..], "pose {k}");
        crossings += expected.len();
    }
    assert!(crossings > 0, "no pose crosses itself");
}

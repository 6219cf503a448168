//! `edges` — CPU twin of `shaders/edges.wgsl`: which mesh edges can be on the silhouette in this
//! view, and on which side their inside lies.
//!
//! An edge is a *candidate* when all of its adjacent, non-culled, non-degenerate faces lie on one
//! side of it in screen space: an open boundary edge (one face), a contour edge (two faces folded
//! onto the same side) or a non-manifold edge whose faces all lie on one side. An edge with faces
//! on both sides is inside the silhouette and skipped.
//!
//! The side test uses the unsnapped `f32` screen positions with an `f64` cross product, computed
//! once per face ([`face_orientations`]); the sign is exact. It is the same geometry as the backward (`edge_grad`)
//! and the exact-area ideal image it differentiates. The snapped fixed-point coordinates of the `coverage`
//! stage must not be used here: a sliver face seen nearly edge-on (common along a contour) can
//! flip or vanish when snapped, which moves the silhouette to the wrong edges and lets the
//! sliver occlude the edges that remain.

use crate::mirror::ScreenVertex;
use crate::scene::mesh::Topology;

/// Orientation of every face in screen space: the sign of `cross(v1 − v0, v2 − v0)` (+1, −1), or 0
/// for a face with a clipped vertex or zero area. f32 differences and their products are exact
/// in f64, so the sign is exact. Reads the screen vertices; writes `orientation` (one per face).
///
/// The stage's definition (the tests' reference): the forward computes the same orientations in
/// `coverage`'s pass over the faces
/// ([`coverage_and_edges`](crate::cpu::coverage::coverage_and_edges)), which reads each face's
/// vertex indices once for both stages.
pub fn face_orientations(screen: &[ScreenVertex], triangles: &[[u32; 3]], orientation: &mut [i8]) {
    for (o, tri) in orientation.iter_mut().zip(triangles) {
        *o = face_orientation(screen, *tri);
    }
}

/// The orientation of one face (see [`face_orientations`]).
#[inline]
pub fn face_orientation(screen: &[ScreenVertex], tri: [u32; 3]) -> i8 {
    // Element by element rather than with `<[_; 3]>::map`, which the compiler left as a call
    // per face (about 2 M instructions of a bunny step).
    let (v0, v1, v2) = (screen[tri[0] as usize], screen[tri[1] as usize], screen[tri[2] as usize]);
    let valid = (v0.valid != 0) & (v1.valid != 0) & (v2.valid != 0);
    let sign = orientation_sign(v0.position, v1.position, v2.position);
    if valid {
        sign
    } else {
        0
    }
}

/// The sign of `cross(p1 − p0, p2 − p0)` (+1, −1, 0), computed in f64, where the f32 differences
/// and their products are exact: the orientation of [`face_orientation`], whatever the vertices'
/// validity.
#[inline(always)]
pub fn orientation_sign(p0: [f32; 2], p1: [f32; 2], p2: [f32; 2]) -> i8 {
    let (x0, y0) = (p0[0] as f64, p0[1] as f64);
    let (x1, y1) = (p1[0] as f64, p1[1] as f64);
    let (x2, y2) = (p2[0] as f64, p2[1] as f64);
    let cross = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0);
    (cross > 0.0) as i8 - (cross < 0.0) as i8
}

/// Side of the inside of a candidate edge `[a, b]`: `+1` when the faces lie to the left of
/// `a → b` (where `cross(b − a, p − a) > 0`, screen y down), `-1` to the right, `0` when the edge
/// is not a candidate. A face `(.., a, b, ..)` that runs `a → b` lies on the side of its own
/// orientation; one that runs `b → a` on the other.
pub fn edge_side(orientation: &[i8], topology: &Topology, edge: usize) -> i32 {
    let range = topology.edge_face_offsets()[edge] as usize..topology.edge_face_offsets()[edge + 1] as usize;
    side_of(orientation, &topology.edge_face_list()[range.clone()], &topology.edge_face_forward()[range])
}

/// [`edge_side`] from the edge's faces and whether each runs along it (`a → b`).
#[inline(always)]
fn side_of(orientation: &[i8], faces: &[u32], forward: &[bool]) -> i32 {
    let (mut left, mut right) = (false, false);
    for (&face, &forward) in faces.iter().zip(forward) {
        // 0 (culled or degenerate) covers nothing on either side.
        let o = orientation[face as usize] as i32;
        let side = if forward { o } else { -o };
        left |= side > 0;
        right |= side < 0;
    }
    match (left, right) {
        (true, false) => 1,
        (false, true) => -1,
        _ => 0,
    }
}

/// Classifies every edge of the topology. Reads the face orientations; writes the candidates
/// `(edge, side)` in edge order into `candidates` (the WGSL stage writes a side per edge instead;
/// the non-candidates are the edges left out here).
///
/// One pass over the edges' two faces ([`Topology::edge_wings`]); only edges with another number
/// of faces read their face lists. The stage's definition (the tests' reference): the forward
/// finds the same candidates in `coverage`'s pass over the edges
/// ([`coverage_and_edges`](crate::cpu::coverage::coverage_and_edges)).
pub fn edges(orientation: &[i8], topology: &Topology, candidates: &mut Vec<(u32, i32)>) {
    let (offsets, faces, forward) =
        (topology.edge_face_offsets(), topology.edge_face_list(), topology.edge_face_forward());
    candidates.clear();
    for (e, &[f, g]) in topology.edge_wings().iter().enumerate() {
        let side = if f != u32::MAX {
            // One face runs along the edge, the other against it: their sides are o(f) and
            // −o(g), and the edge is a candidate exactly when o(f) ≠ o(g) (a shortcut of
            // `side_of`, checked in the tests).
            (orientation[f as usize] as i32 - orientation[g as usize] as i32).signum()
        } else {
            let range = offsets[e] as usize..offsets[e + 1] as usize;
            side_of(orientation, &faces[range.clone()], &forward[range])
        };
        if side != 0 {
            candidates.push((e as u32, side));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two-face shortcut of [`edges`] agrees with [`side_of`] for every pair of orientations.
    #[test]
    fn wing_shortcut_matches_side_of() {
        for a in -1i8..=1 {
            for b in -1i8..=1 {
                let orientation = [a, b];
                let general = side_of(&orientation, &[0, 1], &[true, false]);
                assert_eq!((a as i32 - b as i32).signum(), general, "{a} {b}");
            }
        }
    }

    /// On a random open mesh with boundary edges, edges of three faces, degenerate faces and
    /// clipped vertices, [`face_orientations`] gives the sign of the f64 cross product (0 where a
    /// vertex is clipped) and [`edges`] lists exactly the edges whose [`edge_side`] is not 0, in
    /// edge order, with that side.
    #[test]
    fn candidates_on_open_and_non_manifold_meshes() {
        let mut seed = 0x243f_6a88_85a3_08d3u64;
        let mut rand = move |n: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 33) as u32 % n
        };
        let mut kinds = [0usize; 3];
        for case in 0..20 {
            let n = 12;
            let screen: Vec<ScreenVertex> = (0..n)
                .map(|k| ScreenVertex {
                    // Coarse coordinates so that some faces are degenerate (collinear vertices).
                    position: [rand(4) as f32 * 0.5, rand(4) as f32 * 0.5],
                    valid: (case % 3 != 0 || k % 5 != 2) as u32,
                    pad: 0,
                })
                .collect();
            let mut triangles = Vec::new();
            while triangles.len() < 30 {
                let t = [rand(n), rand(n), rand(n)];
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    triangles.push(t);
                }
            }
            let Ok(topology) = Topology::new(n as usize, triangles.clone()) else { continue };
            let mut orientation = vec![9i8; triangles.len()];
            face_orientations(&screen, &triangles, &mut orientation);
            for (tri, &o) in triangles.iter().zip(&orientation) {
                let v = tri.map(|i| screen[i as usize]);
                let p = v.map(|s| [s.position[0] as f64, s.position[1] as f64]);
                let cross = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
                let expected =
                    if v.iter().any(|s| s.valid == 0) { 0.0 } else { cross.signum() * (cross != 0.0) as u8 as f64 };
                assert_eq!(o as f64, expected, "case {case} {tri:?}");
            }
            let mut candidates = vec![(7, 7)];
            edges(&orientation, &topology, &mut candidates);
            let expected: Vec<(u32, i32)> = (0..topology.edges().len())
                .map(|e| (e as u32, edge_side(&orientation, &topology, e)))
                .filter(|c| c.1 != 0)
                .collect();
            assert_eq!(candidates, expected, "case {case}");
            for e in 0..topology.edges().len() {
                kinds[topology.edge_faces(e).len().min(3) - 1] += 1;
            }
        }
        assert!(kinds.iter().all(|&k| k > 10), "edges with 1, 2 and 3+ faces: {kinds:?}");
    }
}

//! Back-face skipping: the boxes that hold a mesh's oriented boundary in one view, outside which
//! the triangles of negative snapped area add no sample.

use crate::mirror::INVALID_SNAPPED_VERTEX;
use crate::scene::mesh::Topology;

/// Boxes (fixed-point units, `[xmin, ymin, xmax, ymax]`, closed) that hold the oriented boundary
/// of a mesh in one view: outside them, the triangles of negative snapped area cover no sample
/// that the triangles of positive area do not, so [`draw_triangles`](super::draw_triangles) may
/// skip them there.
///
/// Why this is exact. For a triangle of snapped area `A ≠ 0`, the top-left rule's indicator equals
/// `sign(A)` times a sum over its directed edges `a → b`, in the mesh's vertex order, of the
/// half-open crossing count `χ(a → b, p)`: `+1` when `a.y ≤ p.y < b.y` and `p` lies strictly left
/// of the edge, `−1` when `b.y ≤ p.y < a.y` and likewise, else 0 (so `χ(b → a) = −χ(a → b)`;
/// `tl_rule_is_a_crossing_count` checks the identity exhaustively on a small grid). Summed over
/// all triangles, `N₊(p) − N₋(p)` (the numbers of positive and negative triangles covering sample
/// `p`) is `Σ χ` over the directed edges, in which an edge run both ways cancels: what is left is
/// the winding number `B(p)` of the mesh's oriented boundary ([`Topology::boundary_components`]),
/// zero outside each component's bounding box. Where `B(p) = 0`, `N₋(p) > 0` implies `N₊(p) > 0`:
/// a sample covered by a negative triangle is covered by a positive one. So a negative triangle
/// whose box meets no boundary box can be left out, and the union of the rest is the same, bit for
/// bit. A closed, consistently oriented mesh (no boundary) needs no box: about half of its
/// triangles (the back faces, whichever way the camera looks) are skipped. The identity needs
/// every triangle in the sum, so there is no skip when a vertex is clipped.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BackFaceSkip {
    /// The boxes; merged into at most [`BackFaceSkip::MAX_BOXES`].
    pub boxes: Vec<[i32; 4]>,
    /// Their bounding box (empty when there is none), tested first.
    pub union: [i32; 4],
}

impl BackFaceSkip {
    /// Most boxes kept (components beyond are merged into the last boxes, which stays exact:
    /// a box that holds a component's box may replace it).
    pub const MAX_BOXES: usize = 8;

    /// The skip for `topology` seen with these snapped vertices, or `None` (no skip) when a
    /// vertex is clipped.
    pub fn new(topology: &Topology, snapped: &[[i32; 2]]) -> Option<BackFaceSkip> {
        if snapped.contains(&INVALID_SNAPPED_VERTEX) {
            return None;
        }
        let components = topology.boundary_components();
        let count = components.len();
        let kept = count.min(Self::MAX_BOXES);
        let mut boxes = vec![[i32::MAX, i32::MAX, i32::MIN, i32::MIN]; kept];
        for (k, component) in components.enumerate() {
            let b = &mut boxes[k * kept / count];
            for &v in component {
                let p = snapped[v as usize];
                *b = [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])];
            }
        }
        let union = boxes.iter().fold([i32::MAX, i32::MAX, i32::MIN, i32::MIN], |u, b| {
            [u[0].min(b[0]), u[1].min(b[1]), u[2].max(b[2]), u[3].max(b[3])]
        });
        Some(BackFaceSkip { boxes, union })
    }

    /// Whether a negative triangle with this (closed) box may be skipped.
    #[inline]
    pub(super) fn skips(&self, b: [i32; 4]) -> bool {
        let misses = |q: &[i32; 4]| b[0] > q[2] || b[2] < q[0] || b[1] > q[3] || b[3] < q[1];
        misses(&self.union) || self.boxes.iter().all(misses)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::coverage::triangle::area2;
    use crate::cpu::coverage::{damage, draw_triangles, folded_placement, xorshift, SnappedTriangle};
    use crate::mirror::RasterParams;

    /// `χ(a → b, p)` of [`BackFaceSkip`]: the half-open crossing count of a ray from `p` towards +x.
    fn crossing(a: [i64; 2], b: [i64; 2], p: [i64; 2]) -> i64 {
        // E(p) for the edge a → b (positive to the left of a downward edge, y down).
        let e = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        if a[1] <= p[1] && p[1] < b[1] && e > 0 {
            1
        } else if b[1] <= p[1] && p[1] < a[1] && e < 0 {
            -1
        } else {
            0
        }
    }

    /// The lemma behind [`BackFaceSkip`], on every triangle of a 4×4 grid (all vertex orders,
    /// degenerate ones included) and every point around it: the top-left rule's indicator times
    /// the sign of the area is the sum of the crossing counts of the edges in the given order.
    #[test]
    fn tl_rule_is_a_crossing_count() {
        let grid: Vec<[i32; 2]> = (0..16).map(|k| [k % 4 * 2, k / 4 * 2]).collect();
        for a in 0..16u32 {
            for b in 0..16u32 {
                for c in 0..16u32 {
                    let tri = [a, b, c];
                    let v = tri.map(|i| grid[i as usize]).map(|p| [p[0] as i64, p[1] as i64]);
                    let area2 = area2(&v);
                    let snapped = SnappedTriangle::new(&grid, tri);
                    for py in -1..9 {
                        for px in -1..9 {
                            let p = [px, py];
                            let tl = snapped.is_some_and(|t| t.covers(p)) as i64 * area2.signum();
                            let chi: i64 = (0..3).map(|k| crossing(v[k], v[(k + 1) % 3], p)).sum();
                            assert_eq!(tl, chi, "{v:?} at {p:?}");
                        }
                    }
                }
            }
        }
    }

    /// Coverage with [`BackFaceSkip`] equals coverage without it, on closed meshes, meshes with
    /// holes and flipped faces, under random 2D placements of the vertices (wild overlaps,
    /// camera-independent) with many exact ties on sample positions.
    #[test]
    fn back_face_skip_changes_no_sample() {
        let mut rand = xorshift(0x0123_4567_89ab_cdef);
        let sphere = crate::scene::shapes::icosphere(2);
        let closed = sphere.triangles().to_vec();
        let mut skipped_some = false;
        for case in 0..120 {
            let mut triangles = closed.clone();
            damage(&mut triangles, case % 4, &mut rand);
            let f = [1, 3, 4, 5][case % 4];
            let (w, h) = (23 + case as u32 % 9, 17 + case as u32 % 5);
            let mut params = RasterParams::new(w, h, f, 1.0, 0.0).unwrap();
            params.set_tile_size(4);
            let topology = Topology::new(sphere.positions().len(), triangles.clone()).unwrap();
            let screen = folded_placement(sphere.positions(), (w, h, f), 0.45, case % 3 == 0, &mut rand);
            let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
            let skip = BackFaceSkip::new(&topology, &snapped).unwrap();
            assert_eq!(skip.boxes.is_empty(), case % 4 == 0, "case {case}");
            let words = params.pixel_count() * params.words_per_pixel as usize;
            let (mut all, mut culled) = (vec![0u32; words], vec![0u32; words]);
            let a = draw_triangles(&params, &snapped, &triangles, None, &mut vec![[0; 4]; triangles.len()], &mut all);
            let b = draw_triangles(
                &params,
                &snapped,
                &triangles,
                Some(&skip),
                &mut vec![[0; 4]; triangles.len()],
                &mut culled,
            );
            assert_eq!(a, b, "case {case}");
            assert_eq!(all, culled, "case {case}: skipping back faces changed the masks");
            // The skip has teeth: dropping every negative triangle changes the open cases.
            let positive: Vec<[u32; 3]> = triangles
                .iter()
                .copied()
                .filter(|&t| {
                    let v = t.map(|i| snapped[i as usize]).map(|p| [p[0] as i64, p[1] as i64]);
                    (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[1][1] - v[0][1]) * (v[2][0] - v[0][0]) > 0
                })
                .collect();
            let mut front = vec![0u32; words];
            draw_triangles(&params, &snapped, &positive, None, &mut vec![[0; 4]; positive.len()], &mut front);
            if case % 4 == 0 {
                assert_eq!(front, all, "case {case}: a closed mesh's positive triangles cover it all");
            } else {
                skipped_some |= front != all;
            }
        }
        assert!(skipped_some, "no open case needed its negative triangles: the test has no teeth");
    }

    /// A clipped vertex turns the skip off (the identity needs every triangle).
    #[test]
    fn no_back_face_skip_with_a_clipped_vertex() {
        let sphere = crate::scene::shapes::icosphere(1);
        let mut snapped = vec![[5, 5]; sphere.positions().len()];
        assert!(BackFaceSkip::new(sphere.topology(), &snapped).is_some());
        snapped[3] = INVALID_SNAPPED_VERTEX;
        assert!(BackFaceSkip::new(sphere.topology(), &snapped).is_none());
    }
}
